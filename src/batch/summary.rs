//! A batch's summary: `summary.csv` (one row per recording: status, fits before and
//! after, the effects found with their parameters and standard deviations, warnings) and
//! `fleet.md` (the effects most recordings show, and the spread of each parameter across
//! them). Written from the results alone, sorted by name, so that any sharding of a batch
//! merges to the same bytes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::manifest::{check_entry, Manifest};
use super::{io, BatchError, Entry};

/// The summary table's file name.
pub const SUMMARY_FILE: &str = "summary.csv";
/// The fleet report's file name.
pub const FLEET_FILE: &str = "fleet.md";

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
    let csv_path = out.join(SUMMARY_FILE);
    crate::output::write_atomically(&csv_path, csv_text(entries)?).map_err(io(&csv_path))?;
    let md = out.join(FLEET_FILE);
    crate::output::write_atomically(&md, fleet_text(entries)).map_err(io(&md))?;
    Ok(())
}

/// Joins shard folders into `out`: each shard's `batch.json` must describe one batch
/// (job, options, recordings, shard count), every shard given once and none missing;
/// each result whole, unedited, and computed from its recording as it is now. Writes the
/// results, one summary and the batch's manifest. Returns the number of results.
pub fn merge(shards: &[PathBuf], out: &Path) -> Result<usize, BatchError> {
    let merge_err = |message: String| BatchError::Items {
        path: out.to_owned(),
        message,
    };
    let manifests: Vec<Manifest> = shards
        .iter()
        .map(|d| Manifest::read(d))
        .collect::<Result<_, _>>()?;
    let Some(first) = manifests.first() else {
        return Err(merge_err("no shard folders given".into()));
    };
    let mut by_index: BTreeMap<usize, &PathBuf> = BTreeMap::new();
    for (m, dir) in manifests.iter().zip(shards) {
        let d = first.differences(m);
        if !d.is_empty() {
            return Err(merge_err(format!(
                "{} is a shard of another batch than {} (they differ in {}); merge the shards of one batch",
                dir.display(),
                shards[0].display(),
                d.join(", ")
            )));
        }
        if let Some(other) = by_index.insert(m.shard_index, dir) {
            return Err(merge_err(format!(
                "shard {} is given twice ({} and {})",
                m.shard(),
                other.display(),
                dir.display()
            )));
        }
    }
    let missing: Vec<String> = (1..=first.shard_count)
        .filter(|i| !by_index.contains_key(i))
        .map(|i| format!("{i}/{}", first.shard_count))
        .collect();
    if !missing.is_empty() {
        return Err(merge_err(format!(
            "shard(s) {} of the batch's {} are missing: give every shard's folder",
            missing.join(", "),
            first.shard_count
        )));
    }
    let mut all: BTreeMap<String, (Entry, PathBuf)> = BTreeMap::new();
    for (m, dir) in manifests.iter().zip(shards) {
        for item in &m.items[m.shard().range(m.items.len())] {
            let path = super::result_path(dir, &item.name);
            let entry: Entry = std::fs::read(&path)
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok())
                .ok_or_else(|| BatchError::Result {
                    path: path.clone(),
                    message: format!(
                        "no whole result for {} (the shard did not finish); run the shard again",
                        item.name
                    ),
                })?;
            check_entry(m, item, &entry, &path)?;
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
    Manifest {
        shard_index: 1,
        shard_count: 1,
        fingerprints: {
            let mut in_order: Vec<&Manifest> = manifests.iter().collect();
            in_order.sort_by_key(|m| m.shard_index);
            in_order
                .iter()
                .flat_map(|m| m.fingerprints.iter().cloned())
                .collect()
        },
        ..first.clone()
    }
    .write(out)?;
    Ok(entries.len())
}
