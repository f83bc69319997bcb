//! Batches: one diagnosis or calibration per recording of a fleet (a folder, or a list
//! file), in parallel, shardable like sweeps, each result written whole as it finishes
//! (`results/NAME.json`, with the full report beside it), so that an interrupted batch
//! goes on where it stopped, and a merge of the results into one summary table and a
//! short report of what the fleet shares ([`summary`]).
//!
//! A result is kept on a rerun only if its fingerprint (the recording's and the rig's or
//! scene's bytes, the job's options and agvsim's version) is the same.

mod items;
mod manifest;
pub mod summary;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

pub use items::{find_items, Item};

use crate::shard::Shard;

/// What each recording gets.
#[derive(Debug, Clone)]
pub enum Job {
    /// `diagnose` against the item's rig.
    Diagnose {
        /// Effects to try.
        effects: crate::ident::effects::Choice,
        /// The effect words as given (for the fingerprint).
        effect_words: Vec<String>,
    },
    /// `calibrate` of one scene to each recording.
    Calibrate {
        /// The scene file.
        scene: PathBuf,
        /// Effects to try.
        effects: crate::ident::effects::Choice,
        /// The effect words as given (for the fingerprint).
        effect_words: Vec<String>,
    },
}

/// One effect a result found (diagnose) or accepted (calibrate).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoundEffect {
    /// The contract's effect name.
    pub name: String,
    /// Its parameter or scene key.
    pub key: String,
    /// Its value.
    pub value: f64,
    /// One standard deviation (`None`: not determined).
    pub std: Option<f64>,
}

/// One recording's result, as `results/NAME.json` holds it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// The item's name (the recording's file stem).
    pub name: String,
    /// The recording as the batch found it.
    pub recording: String,
    /// What the result was computed from (see the module's doc).
    pub fingerprint: String,
    /// `ok`, or `error` with its message.
    pub status: String,
    /// The error, if any.
    pub error: Option<String>,
    /// Mean fit before (the rig's nominal model, or the scene as written), %.
    pub fit_before_pct: Option<f64>,
    /// Mean fit after (the diagnosed model, or the calibrated scene), %.
    pub fit_after_pct: Option<f64>,
    /// Effects found or accepted, in order.
    pub effects: Vec<FoundEffect>,
    /// The fitted parameters or calibrated keys, by name.
    pub params: BTreeMap<String, f64>,
    /// Things to know (a parameter at a bound, outputs left out).
    pub warnings: Vec<String>,
    /// The fingerprint of the entry's own contents as written (this field empty) and of
    /// its shard's manifest (its seal): a result edited since, or moved to another batch's
    /// folder, does not merge. (Numbers read back exactly: serde_json's `float_roundtrip`.)
    /// It is a check against accidents (a hand edit, a file from another run, a truncated
    /// copy), not a signature: the hash is unkeyed, and whoever can write the files can
    /// recompute it (docs/fleet.md).
    #[serde(default)]
    pub seal: String,
}

impl Entry {
    fn contents_print(&self, manifest_seal: &str) -> String {
        let mut bare = self.clone();
        bare.seal = String::new();
        fnv1a(&[
            serde_json::to_string(&bare).unwrap_or_default().as_bytes(),
            manifest_seal.as_bytes(),
        ])
    }

    /// The entry with its seal set, bound to its shard's manifest's seal.
    pub fn sealed(mut self, manifest_seal: &str) -> Entry {
        self.seal = self.contents_print(manifest_seal);
        self
    }

    /// Whether the entry is as it was sealed under the manifest sealed `manifest_seal`.
    pub fn seal_holds(&self, manifest_seal: &str) -> bool {
        self.seal == self.contents_print(manifest_seal)
    }

    /// The first value no result can have (a fit above 100 %, a number that is not
    /// finite, a negative standard deviation), in words.
    pub fn impossible_value(&self) -> Option<String> {
        for (what, v) in [
            ("fit_before_pct", self.fit_before_pct),
            ("fit_after_pct", self.fit_after_pct),
        ] {
            if let Some(v) = v {
                // A fit (100 (1 - |e| / |y - mean y|)) is at most 100 %; far below zero
                // is a model that diverged, which the batch reports as it is.
                if !(v.is_finite() && v <= 100.0) {
                    return Some(format!("{what} = {v}: a fit is at most 100 %"));
                }
            }
        }
        for e in &self.effects {
            if !e.value.is_finite() || e.std.is_some_and(|s| !(s.is_finite() && s >= 0.0)) {
                return Some(format!(
                    "effect {} ({}) = {} +/- {:?}: expected a finite value and a standard deviation of zero or more",
                    e.name, e.key, e.value, e.std
                ));
            }
        }
        self.params
            .iter()
            .find(|(_, v)| !v.is_finite())
            .map(|(k, v)| format!("{k} = {v}: expected a finite number"))
    }
}

/// Why a batch could not run.
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// Every recording of the batch (or of its shard) failed: the summary says why.
    #[error("every one of the {failed} recordings failed; {} says why", summary.display())]
    AllFailed {
        /// Recordings that failed.
        failed: usize,
        /// The summary written.
        summary: PathBuf,
    },
    /// The recordings could not be found or listed.
    #[error("{path}: {message}")]
    Items {
        /// The folder or list file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A file that could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A recording (or its rig or scene) removed since the batch ran.
    #[error("{} is gone since the batch ran", path.display())]
    Gone {
        /// The file.
        path: PathBuf,
    },
    /// A result, summary or manifest of a batch that cannot be used (the message says
    /// why).
    #[error("{}: {message}", path.display())]
    Result {
        /// The file.
        path: PathBuf,
        /// The reader's complaint.
        message: String,
    },
}

/// Why one recording of a batch has no result (kept in its entry; the batch goes on).
#[derive(Debug, thiserror::Error)]
pub enum ItemError {
    /// A recording diagnosed without a rig.
    #[error("no rig for {0}: put NAME.rig.toml beside it, name it in the list, or give --rig")]
    NoRig(String),
    /// The rig does not load.
    #[error(transparent)]
    Rig(#[from] crate::rig::RigError),
    /// The recording does not load.
    #[error(transparent)]
    Recording(#[from] crate::record::RecordingError),
    /// The scene does not load.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// The diagnosis failed.
    #[error(transparent)]
    Diagnose(#[from] crate::ident::IdentError),
    /// The calibration failed.
    #[error(transparent)]
    Calibrate(#[from] crate::calibrate::CalibrateError),
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> BatchError + '_ {
    move |source| BatchError::Io {
        path: path.to_owned(),
        source,
    }
}

/// The fingerprint of a `kind` job (`diagnose` or `calibrate`) on `recording` with its
/// rig or scene `model` and effect words: their bytes, the options and agvsim's version.
pub(crate) fn fingerprint_of(
    kind: &str,
    recording: &Path,
    model: Option<&Path>,
    words: &[String],
) -> Result<String, BatchError> {
    let read = |p: &Path| std::fs::read(p).map_err(io(p));
    let recording = read(recording)?;
    let model = model.map(read).transpose()?.unwrap_or_default();
    let words = words.join(",");
    Ok(fnv1a(&[
        kind.as_bytes(),
        env!("CARGO_PKG_VERSION").as_bytes(),
        &recording,
        &model,
        words.as_bytes(),
    ]))
}

/// FNV-1a, 64 bits: a fingerprint stable across runs, builds and platforms.
fn fnv1a(parts: &[&[u8]]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for b in part.iter().chain(&[0xff]) {
            h ^= u64::from(*b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    format!("{h:016x}")
}

impl Job {
    /// The fingerprint of this job on `item`.
    pub fn fingerprint(&self, item: &Item) -> Result<String, BatchError> {
        match self {
            Job::Diagnose { effect_words, .. } => fingerprint_of(
                "diagnose",
                &item.recording,
                item.rig.as_deref(),
                effect_words,
            ),
            Job::Calibrate {
                scene,
                effect_words,
                ..
            } => fingerprint_of("calibrate", &item.recording, Some(scene), effect_words),
        }
    }

    /// Runs the job on one item: its entry and its full report (text).
    pub fn run(&self, item: &Item, fingerprint: String) -> (Entry, String) {
        let mut entry = Entry {
            name: item.name.clone(),
            recording: item.shown.clone(),
            fingerprint,
            status: "ok".into(),
            error: None,
            fit_before_pct: None,
            fit_after_pct: None,
            effects: vec![],
            params: BTreeMap::new(),
            warnings: vec![],
            seal: String::new(),
        };
        let report = match self {
            Job::Diagnose { effects, .. } => diagnose_one(item, effects, &mut entry),
            Job::Calibrate { scene, effects, .. } => {
                calibrate_one(item, scene, effects, &mut entry)
            }
        };
        match report {
            Ok(text) => (entry, text),
            Err(e) => {
                let message = e.to_string();
                entry.status = "error".into();
                entry.error = Some(message.clone());
                (entry, format!("error: {message}\n"))
            }
        }
    }
}

fn diagnose_one(
    item: &Item,
    effects: &crate::ident::effects::Choice,
    e: &mut Entry,
) -> Result<String, ItemError> {
    let rig_path = item
        .rig
        .as_deref()
        .ok_or_else(|| ItemError::NoRig(item.shown.clone()))?;
    let rig = crate::rig::Rig::load(rig_path)?;
    let rec = crate::record::Recording::load(&item.recording)?;
    let opts = crate::diagnose::DiagnoseOptions {
        effects: effects.clone(),
        ..Default::default()
    };
    let d = crate::diagnose::diagnose(&rig, rig_path, &rec, None, &opts)?;
    e.fit_before_pct = Some(d.baseline_fit_pct);
    e.fit_after_pct = Some(d.final_fit_pct);
    e.effects = d
        .findings
        .iter()
        .map(|f| FoundEffect {
            name: f.effect.name().into(),
            key: f.param.clone(),
            value: f.value,
            std: f.std,
        })
        .chain(d.terms.iter().filter_map(|t| {
            let (key, value) = t.row.params.first()?;
            Some(FoundEffect {
                name: t.row.name.clone(),
                key: key.clone(),
                value: value.as_f64()?,
                std: t.row.std,
            })
        }))
        .collect();
    e.params = d.final_params.clone();
    for (k, b) in &d.baseline_at_bound {
        e.warnings
            .push(format!("baseline {k} at its bound {}", summary::num(*b)));
    }
    for l in &d.left_out {
        e.warnings.push(format!("{} left out", l.output));
    }
    Ok(crate::diagnose::report::render(&d))
}

fn calibrate_one(
    item: &Item,
    scene_path: &Path,
    effects: &crate::ident::effects::Choice,
    e: &mut Entry,
) -> Result<String, ItemError> {
    let scene = crate::scene::Scene::load(scene_path, &[])?;
    let rec = crate::record::Recording::load(&item.recording)?;
    let request = crate::calibrate::Request {
        free: vec![],
        effects: effects.clone(),
        validate: None,
    };
    let c = crate::calibrate::calibrate_telling(&scene, &rec, &request, &|_| {})?;
    use crate::calibrate::write as cw;
    e.fit_before_pct = Some(cw::mean_fit(&c.before, &c.outputs));
    e.fit_after_pct = Some(cw::mean_fit(&c.after, &c.outputs));
    e.effects = c
        .effects
        .iter()
        .filter(|t| t.accepted)
        .map(|t| FoundEffect {
            name: t.effect.name().into(),
            key: t.key.clone(),
            value: t.value,
            std: t.std,
        })
        .collect();
    for k in &c.keys {
        e.params.insert(k.key.clone(), k.after);
        if let Some(b) = k.at_bound {
            e.warnings
                .push(format!("{} at its bound {}", k.key, summary::num(b)));
        }
        if k.held {
            e.warnings
                .push(format!("{} held by its stated belief", k.key));
        }
    }
    for l in &c.left_out {
        e.warnings.push(format!("{} left out", l.output));
    }
    Ok(cw::render(&c))
}

/// What a batch did.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// Recordings in this shard.
    pub in_shard: usize,
    /// Results kept from an earlier, interrupted run.
    pub kept: usize,
    /// Results computed now.
    pub computed: usize,
    /// Of all this shard's results, those that failed.
    pub failed: usize,
}

/// Where an item's result goes.
pub fn result_path(out: &Path, name: &str) -> PathBuf {
    out.join("results").join(format!("{name}.json"))
}

/// Reads a result file, `None` if it is missing, not a result or not as written (it is
/// then redone).
fn read_entry(path: &Path, manifest_seal: &str) -> Option<Entry> {
    serde_json::from_slice::<Entry>(&std::fs::read(path).ok()?)
        .ok()
        .filter(|e| e.seal_holds(manifest_seal))
}

/// Runs `job` on this shard's items in parallel (on the current rayon pool), writing each
/// result as it finishes and keeping those an earlier run finished; `told` hears each
/// entry as it is written. Writes the shard's summary at the end.
pub fn run(
    job: &Job,
    items: &[Item],
    shard: Shard,
    out: &Path,
    told: &(dyn Fn(&Entry, bool) + Sync),
) -> Result<Outcome, BatchError> {
    use rayon::prelude::*;
    let mine = &items[shard.range(items.len())];
    let results = out.join("results");
    std::fs::create_dir_all(&results).map_err(io(&results))?;
    let prints: Vec<String> = mine
        .iter()
        .map(|i| job.fingerprint(i))
        .collect::<Result<_, _>>()?;
    // What this folder is part of, before any work; a summary of an earlier run goes, so
    // that a run stopped midway leaves none that reads as this one's.
    let manifest = manifest::Manifest::new(job, items, shard, &prints);
    manifest.write(out)?;
    for old in [summary::SUMMARY_FILE, summary::FLEET_FILE] {
        let p = out.join(old);
        match std::fs::remove_file(&p) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io(&p)(e)),
            _ => {}
        }
    }
    let outcomes: Vec<Result<(Entry, bool), BatchError>> = mine
        .par_iter()
        .zip(prints.par_iter())
        .map(|(item, print)| {
            let path = result_path(out, &item.name);
            if let Some(e) = read_entry(&path, &manifest.seal).filter(|e| &e.fingerprint == print) {
                told(&e, true);
                return Ok((e, true));
            }
            let (entry, report) = job.run(item, print.clone());
            let entry = entry.sealed(&manifest.seal);
            let text = results.join(format!("{}.txt", item.name));
            crate::output::write_atomically(&text, report).map_err(io(&text))?;
            let json = serde_json::to_string_pretty(&entry).unwrap_or_default();
            // The entry last: its presence marks the result finished.
            crate::output::write_atomically(&path, json + "\n").map_err(io(&path))?;
            told(&entry, false);
            Ok((entry, false))
        })
        .collect();
    let mut entries = Vec::new();
    let mut kept = 0;
    for o in outcomes {
        let (e, was_kept) = o?;
        kept += usize::from(was_kept);
        entries.push(e);
    }
    let failed = entries.iter().filter(|e| e.status != "ok").count();
    summary::write(out, &entries)?;
    Ok(Outcome {
        in_shard: mine.len(),
        kept,
        computed: mine.len() - kept,
        failed,
    })
}

#[cfg(test)]
mod seal_tests {
    use super::*;

    #[test]
    fn a_sealed_entry_read_back_holds_and_an_edited_one_does_not() {
        let mut params = BTreeMap::new();
        params.insert("motor.coulomb_Nm".to_string(), 1.0 / 3.0);
        params.insert("gearbox.backlash_rad".to_string(), 0.1 + 0.2);
        let entry = Entry {
            name: "a".into(),
            recording: "a.csv".into(),
            fingerprint: "0123".into(),
            status: "ok".into(),
            error: None,
            fit_before_pct: Some(81.234_567_891_234_5),
            fit_after_pct: Some(97.0e-3 / 7.0),
            effects: vec![],
            params,
            warnings: vec![],
            seal: String::new(),
        }
        .sealed("m1");
        let text = serde_json::to_string_pretty(&entry).unwrap();
        let back: Entry = serde_json::from_str(&text).unwrap();
        assert!(back.seal_holds("m1"));
        assert!(!back.seal_holds("m2"), "another batch's manifest");
        let edited: Entry =
            serde_json::from_str(&text.replace("81.2345678912345", "1e308")).unwrap();
        assert!(!edited.seal_holds("m1"));
        assert!(back.impossible_value().is_none());
        let resealed = Entry {
            fit_after_pct: Some(123456.0),
            ..back
        }
        .sealed("m1");
        assert!(resealed.seal_holds("m1"));
        assert!(resealed
            .impossible_value()
            .unwrap()
            .contains("at most 100 %"));
    }
}
