//! A batch's summary: `summary.csv` (one row per recording: status, fits before and
//! after, the effects found with their parameters and standard deviations, warnings) and
//! `fleet.md` (the effects most recordings show, and the spread of each parameter across
//! them). Written from the results alone, sorted by name, so that any sharding of a batch
//! merges to the same bytes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::{io, read_entry, BatchError, Entry};

/// A number as the summary prints it: 6 significant figures, plain.
pub(crate) fn num(v: f64) -> String {
    crate::numtext::sig(v, 6)
}

fn effect_cell(e: &Entry) -> String {
    e.effects
        .iter()
        .map(|f| match f.std {
            Some(s) => format!("{} {}={} +- {}", f.name, f.key, num(f.value), num(s)),
            None => format!("{} {}={} (std not determined)", f.name, f.key, num(f.value)),
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// `summary.csv`'s text.
pub fn csv_text(entries: &[Entry]) -> Result<String, BatchError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let row = |w: &mut csv::Writer<Vec<u8>>, r: &[String]| {
        w.write_record(r).map_err(|e| BatchError::Result {
            path: PathBuf::from("summary.csv"),
            message: e.to_string(),
        })
    };
    row(
        &mut w,
        &[
            "recording",
            "status",
            "fit_before_pct",
            "fit_after_pct",
            "effects",
            "warnings",
            "error",
        ]
        .map(String::from),
    )?;
    let opt = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:.2}"));
    for e in sorted(entries) {
        row(
            &mut w,
            &[
                e.recording.clone(),
                e.status.clone(),
                opt(e.fit_before_pct),
                opt(e.fit_after_pct),
                effect_cell(e),
                e.warnings.join("; "),
                e.error.clone().unwrap_or_default(),
            ],
        )?;
    }
    let bytes = w.into_inner().map_err(|e| BatchError::Result {
        path: PathBuf::from("summary.csv"),
        message: e.to_string(),
    })?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

fn sorted(entries: &[Entry]) -> Vec<&Entry> {
    let mut v: Vec<&Entry> = entries.iter().collect();
    v.sort_by(|a, b| a.name.cmp(&b.name));
    v
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// `fleet.md`'s text: what the fleet shares.
pub fn fleet_text(entries: &[Entry]) -> String {
    let ok: Vec<&Entry> = sorted(entries)
        .into_iter()
        .filter(|e| e.status == "ok")
        .collect();
    let failed = entries.len() - ok.len();
    let mut out = format!(
        "# Fleet summary\n\n{} recordings, {} with a result{}.\n\n## Effects\n\n",
        entries.len(),
        ok.len(),
        if failed > 0 {
            format!(", {failed} failed (see summary.csv)")
        } else {
            String::new()
        }
    );
    let mut by_effect: BTreeMap<&str, Vec<(&str, f64)>> = BTreeMap::new();
    for e in &ok {
        for f in &e.effects {
            by_effect
                .entry(&f.name)
                .or_default()
                .push((&f.key, f.value));
        }
    }
    let mut ranked: Vec<(&str, &Vec<(&str, f64)>)> =
        by_effect.iter().map(|(k, v)| (*k, v)).collect();
    ranked.sort_by(|a, b| b.1.len().cmp(&a.1.len()).then(a.0.cmp(b.0)));
    if ranked.is_empty() {
        out.push_str("No recording shows an effect.\n");
    } else {
        out.push_str("| effect | recordings | share | parameter: median (min to max) |\n| --- | --- | --- | --- |\n");
        for (name, found) in ranked {
            let mut by_key: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
            for (k, v) in found {
                by_key.entry(k).or_default().push(*v);
            }
            let spread = by_key
                .iter_mut()
                .map(|(k, v)| {
                    let (lo, hi) = (
                        v.iter().copied().fold(f64::INFINITY, f64::min),
                        v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                    );
                    format!("{k}: {} ({} to {})", num(median(v)), num(lo), num(hi))
                })
                .collect::<Vec<_>>()
                .join("; ");
            out.push_str(&format!(
                "| {name} | {} of {} | {:.0} % | {spread} |\n",
                found.len(),
                ok.len(),
                100.0 * found.len() as f64 / ok.len().max(1) as f64
            ));
        }
    }
    out.push_str("\n## Parameters across recordings\n\n");
    let mut by_param: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for e in &ok {
        for (k, v) in &e.params {
            by_param.entry(k).or_default().push(*v);
        }
    }
    if by_param.is_empty() {
        out.push_str("None.\n");
    } else {
        out.push_str("| parameter | recordings | median | min | max | spread (max/min) |\n| --- | --- | --- | --- | --- | --- |\n");
        for (k, v) in by_param.iter_mut() {
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let ratio = if lo > 0.0 {
                format!("{:.2}", hi / lo)
            } else {
                "-".into()
            };
            out.push_str(&format!(
                "| {k} | {} | {} | {} | {} | {ratio} |\n",
                v.len(),
                num(median(v)),
                num(lo),
                num(hi)
            ));
        }
    }
    out
}

/// Writes `summary.csv` and `fleet.md` for `entries` into `out`.
pub fn write(out: &Path, entries: &[Entry]) -> Result<(), BatchError> {
    let csv_path = out.join("summary.csv");
    crate::output::write_atomically(&csv_path, csv_text(entries)?).map_err(io(&csv_path))?;
    let md = out.join("fleet.md");
    crate::output::write_atomically(&md, fleet_text(entries)).map_err(io(&md))?;
    Ok(())
}

/// The finished results in a batch folder.
pub fn read_results(dir: &Path) -> Result<Vec<(Entry, PathBuf)>, BatchError> {
    let results = dir.join("results");
    let listing = std::fs::read_dir(&results).map_err(io(&results))?;
    let mut out = Vec::new();
    for e in listing {
        let p = e.map_err(io(&results))?.path();
        let is_result = p.extension().is_some_and(|x| x == "json");
        if is_result {
            let entry = read_entry(&p).ok_or_else(|| BatchError::Result {
                path: p.clone(),
                message: "expected the JSON of a batch result".into(),
            })?;
            out.push((entry, p));
        }
    }
    Ok(out)
}

/// Joins shard folders into `out`: their results (each recording once; two shards with
/// different results for one are refused) and one summary. Returns the number of results.
pub fn merge(shards: &[PathBuf], out: &Path) -> Result<usize, BatchError> {
    let mut all: BTreeMap<String, (Entry, PathBuf)> = BTreeMap::new();
    for dir in shards {
        for (entry, path) in read_results(dir)? {
            if let Some((other, other_path)) = all.get(&entry.name) {
                if *other != entry {
                    return Err(BatchError::Conflict {
                        name: entry.name.clone(),
                        a: other_path.display().to_string(),
                        b: path.display().to_string(),
                    });
                }
                continue;
            }
            all.insert(entry.name.clone(), (entry, path));
        }
    }
    let results = out.join("results");
    std::fs::create_dir_all(&results).map_err(io(&results))?;
    for (name, (_, path)) in &all {
        for ext in ["json", "txt"] {
            let from = path.with_extension(ext);
            if from.is_file() {
                let to = results.join(format!("{name}.{ext}"));
                let bytes = std::fs::read(&from).map_err(io(&from))?;
                crate::output::write_atomically(&to, bytes).map_err(io(&to))?;
            }
        }
    }
    let entries: Vec<Entry> = all.into_values().map(|(e, _)| e).collect();
    write(out, &entries)?;
    Ok(entries.len())
}
