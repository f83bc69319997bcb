//! A batch's identity, written into every shard folder as `batch.json` before any work:
//! the job and its options, every recording of the batch (by name and path, in order),
//! the shard count and this shard's index, and the fingerprint of each recording this
//! shard works on. A merge checks every shard against it: shards of one batch, each
//! given once, none missing, each result whole, unedited and computed from the
//! recording as it is now.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{fingerprint_of, io, BatchError, Entry, Item, Job};
use crate::shard::Shard;

/// The manifest's file name inside a batch's output folder.
pub const MANIFEST_FILE: &str = "batch.json";

/// One recording of the batch.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ManifestItem {
    /// Its name (the result's file stem).
    pub name: String,
    /// The recording, as an absolute path.
    pub recording: PathBuf,
    /// Its rig (diagnose), as an absolute path.
    pub rig: Option<PathBuf>,
}

/// What one shard folder was computed as part of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// agvsim's version.
    pub agvsim: String,
    /// `diagnose` or `calibrate`.
    pub job: String,
    /// The scene calibrated (calibrate), as an absolute path.
    pub scene: Option<PathBuf>,
    /// The effect words as given.
    pub effects: Vec<String>,
    /// Every recording of the batch, in the batch's order.
    pub items: Vec<ManifestItem>,
    /// This shard's index, from 1.
    pub shard_index: usize,
    /// The batch's number of shards.
    pub shard_count: usize,
    /// The fingerprint of each recording of this shard, by name, when it started.
    pub fingerprints: Vec<(String, String)>,
    /// The fingerprint of the manifest's own contents as written (this field empty); each
    /// result's seal includes it. A manifest edited since (recordings cut from its list,
    /// its shard count or `--effects` changed) does not merge. Unkeyed, as the results'
    /// seals: a check against accidents, not a signature.
    #[serde(default)]
    pub seal: String,
}

fn absolute(p: &Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| {
        std::env::current_dir()
            .map(|d| d.join(p))
            .unwrap_or_else(|_| p.to_path_buf())
    })
}

impl Manifest {
    /// The manifest of `job` on `items`, shard `shard` (`prints`: the shard's items'
    /// fingerprints, in order).
    pub fn new(job: &Job, items: &[Item], shard: Shard, prints: &[String]) -> Manifest {
        let (kind, scene, words) = match job {
            Job::Diagnose { effect_words, .. } => ("diagnose", None, effect_words),
            Job::Calibrate {
                scene,
                effect_words,
                ..
            } => ("calibrate", Some(absolute(scene)), effect_words),
        };
        let mine = &items[shard.range(items.len())];
        let mut m = Manifest {
            agvsim: env!("CARGO_PKG_VERSION").to_string(),
            job: kind.to_string(),
            scene,
            effects: words.clone(),
            items: items
                .iter()
                .map(|i| ManifestItem {
                    name: i.name.clone(),
                    recording: absolute(&i.recording),
                    rig: i.rig.as_deref().map(absolute),
                })
                .collect(),
            shard_index: shard.index,
            shard_count: shard.count,
            fingerprints: mine
                .iter()
                .zip(prints)
                .map(|(i, p)| (i.name.clone(), p.clone()))
                .collect(),
            seal: String::new(),
        };
        m.seal = m.contents_print();
        m
    }

    fn contents_print(&self) -> String {
        let mut bare = self.clone();
        bare.seal = String::new();
        super::fnv1a(&[serde_json::to_string(&bare).unwrap_or_default().as_bytes()])
    }

    /// Writes `DIR/batch.json`.
    pub fn write(&self, dir: &Path) -> Result<(), BatchError> {
        let path = dir.join(MANIFEST_FILE);
        let text = serde_json::to_string_pretty(self).unwrap_or_default() + "\n";
        crate::output::write_atomically(&path, text).map_err(io(&path))
    }

    /// Reads `DIR/batch.json`.
    pub fn read(dir: &Path) -> Result<Manifest, BatchError> {
        let path = dir.join(MANIFEST_FILE);
        let bytes = std::fs::read(&path).map_err(|_| BatchError::Result {
            path: path.clone(),
            message: "missing: not a batch's output folder (or one written by an agvsim that did not record its batch); run the shard again".into(),
        })?;
        let m: Manifest = serde_json::from_slice(&bytes).map_err(|e| BatchError::Result {
            path: path.clone(),
            message: format!("not a batch manifest: {e}"),
        })?;
        if m.shard_count == 0 || !(1..=m.shard_count).contains(&m.shard_index) {
            return Err(BatchError::Result {
                path,
                message: format!(
                    "shard {} of {}: expected a shard from 1 to the count (edited?)",
                    m.shard_index, m.shard_count
                ),
            });
        }
        if m.seal != m.contents_print() {
            return Err(BatchError::Result {
                path,
                message: "its contents differ from what the batch wrote (its recordings, shard count or --effects edited since?); run the shard again".into(),
            });
        }
        Ok(m)
    }

    /// This shard.
    pub fn shard(&self) -> Shard {
        Shard {
            index: self.shard_index,
            count: self.shard_count,
        }
    }

    /// What differs between two manifests' batches (job, options, recordings, shard
    /// count), in words; empty when they are shards of one batch.
    pub fn differences(&self, other: &Manifest) -> Vec<&'static str> {
        let mut d = vec![];
        if self.agvsim != other.agvsim {
            d.push("agvsim version");
        }
        if self.job != other.job || self.scene != other.scene {
            d.push("job (diagnose or calibrate, and the scene)");
        }
        if self.effects != other.effects {
            d.push("--effects");
        }
        if self.items != other.items {
            d.push("the recordings (names, paths or rigs)");
        }
        if self.shard_count != other.shard_count {
            d.push("the shard count");
        }
        d
    }

    /// The fingerprint `name`'s recording (and rig or scene) has now, or why it has none.
    pub fn fingerprint_now(&self, item: &ManifestItem) -> Result<String, BatchError> {
        let model = match self.job.as_str() {
            "calibrate" => self.scene.as_deref(),
            _ => item.rig.as_deref(),
        };
        for p in [Some(item.recording.as_path()), model]
            .into_iter()
            .flatten()
        {
            if !p.is_file() {
                return Err(BatchError::Gone { path: p.to_owned() });
            }
        }
        fingerprint_of(&self.job, &item.recording, model, &self.effects)
    }
}

/// Checks that `entry` (read from `path`) is the whole, unedited result `manifest`'s
/// shard computed for `item`, from the recording as it is now.
pub fn check_entry(
    manifest: &Manifest,
    item: &ManifestItem,
    entry: &Entry,
    path: &Path,
) -> Result<(), BatchError> {
    let bad = |message: String| BatchError::Result {
        path: path.to_owned(),
        message,
    };
    if !entry.seal_holds(&manifest.seal) {
        return Err(bad(
            "its contents differ from what the batch wrote, or it was written for another batch.json (edited or copied since?); run its shard again"
                .into(),
        ));
    }
    if let Some(why) = entry.impossible_value() {
        return Err(bad(format!("{why}; run its shard again")));
    }
    let started = manifest
        .fingerprints
        .iter()
        .find(|(n, _)| *n == item.name)
        .map(|(_, p)| p);
    if started != Some(&entry.fingerprint) {
        return Err(bad(
            "computed by an earlier run of the shard folder, not by the batch its batch.json describes; run the shard again".into(),
        ));
    }
    let now = manifest
        .fingerprint_now(item)
        .map_err(|e| bad(e.to_string()))?;
    if now != entry.fingerprint {
        return Err(bad(format!(
            "{} (or its rig or scene) changed since this result was computed; run its shard again",
            item.recording.display()
        )));
    }
    Ok(())
}
