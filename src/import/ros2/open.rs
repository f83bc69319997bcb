//! Opening a bag: its storage found (a file's extension, or a rosbag2 folder's
//! metadata.yaml), each storage file checked and read by its format's reader, and the
//! topics' messages put in time order.

use std::collections::BTreeMap;
use std::path::Path;

use crate::import::bag::{
    bad, declare_topic, Bag, BagError, Budget, Storage, Topic, MAX_BAG_BYTES, MAX_METADATA_BYTES,
};

/// Reads a bag: an `.mcap` or `.db3` file, or a rosbag2 folder.
pub fn open(path: &Path) -> Result<Bag, BagError> {
    let io = |p: &Path| {
        let p = p.to_owned();
        move |source| BagError::Io { path: p, source }
    };
    let meta = std::fs::metadata(path).map_err(io(path))?;
    let mut topics: BTreeMap<String, Topic> = BTreeMap::new();
    let mut budget = Budget::default();
    let storage = if meta.is_dir() {
        let info = folder_info(path)?;
        for f in &info.files {
            read_file(&path.join(f), info.storage, &mut topics, &mut budget)?;
        }
        for (name, ty, count) in &info.topics {
            let t = declare_topic(&mut topics, name, ty);
            if t.messages.len() < *count {
                return Err(bad(
                    path,
                    format!(
                        "topic `{name}`: metadata.yaml counts {count} messages, the storage holds {} (a recording cut short?)",
                        t.messages.len()
                    ),
                ));
            }
        }
        info.storage
    } else {
        let storage = storage_of_file(path)?;
        read_file(path, storage, &mut topics, &mut budget)?;
        storage
    };
    let mut topics: Vec<Topic> = topics.into_values().collect();
    for t in &mut topics {
        t.messages.sort_by_key(|m| m.log_time_ns);
    }
    Ok(Bag {
        path: path.to_owned(),
        storage,
        topics,
    })
}

fn storage_of_file(path: &Path) -> Result<Storage, BagError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("mcap") => Ok(Storage::Mcap),
        Some("db3") => Ok(Storage::Sqlite3),
        Some("bag") => Ok(Storage::Rosbag1),
        _ => Err(bad(
            path,
            "expected an .mcap or .db3 file, a rosbag2 folder holding metadata.yaml, or a ROS 1 .bag file",
        )),
    }
}

/// What a rosbag2 folder's `metadata.yaml` says.
struct FolderInfo {
    storage: Storage,
    files: Vec<String>,
    /// (topic, type, message count).
    topics: Vec<(String, String, usize)>,
}

fn folder_info(dir: &Path) -> Result<FolderInfo, BagError> {
    let file = dir.join("metadata.yaml");
    if !file.exists() {
        return Err(bad(
            dir,
            "no metadata.yaml: a rosbag2 folder holds one beside its .mcap or .db3 files (give the .mcap or .db3 file itself to read it alone)",
        ));
    }
    // metadata.yaml is a few kilobytes; a device or a gigabyte file is not one.
    match std::fs::metadata(&file) {
        Ok(m) if !m.is_file() || m.len() > MAX_METADATA_BYTES => {
            return Err(bad(
                &file,
                format!("expected a rosbag2 metadata file: a regular file of at most {MAX_METADATA_BYTES} bytes"),
            ))
        }
        _ => {}
    }
    let text = crate::output::read_text_bounded(&file, MAX_METADATA_BYTES).map_err(|source| {
        BagError::Io {
            path: file.clone(),
            source,
        }
    })?;
    let doc: serde_yaml::Value =
        serde_yaml::from_str(&text).map_err(|e| bad(&file, format!("not YAML: {e}")))?;
    let info = &doc["rosbag2_bagfile_information"];
    if info.is_null() {
        return Err(bad(&file, "no `rosbag2_bagfile_information` section"));
    }
    let storage = match info["storage_identifier"].as_str() {
        Some("mcap") => Storage::Mcap,
        Some("sqlite3") => Storage::Sqlite3,
        other => {
            return Err(bad(
                &file,
                format!("storage_identifier {other:?}: expected `mcap` or `sqlite3`"),
            ))
        }
    };
    let files: Vec<String> = info["relative_file_paths"]
        .as_sequence()
        .map(|s| {
            s.iter()
                .filter_map(|v| v.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default();
    if files.is_empty() {
        return Err(bad(&file, "`relative_file_paths` lists no storage file"));
    }
    storage_files_inside(dir, &file, &files)?;
    if !info["compression_mode"].as_str().unwrap_or("").is_empty() {
        return Err(bad(
            &file,
            format!(
                "compression_mode `{}`: a bag compressed by rosbag2 as a whole is not read; decompress it with `ros2 bag convert` (MCAP's own chunk compression is read)",
                info["compression_mode"].as_str().unwrap_or("")
            ),
        ));
    }
    let topics = info["topics_with_message_count"]
        .as_sequence()
        .map(|s| {
            s.iter()
                .filter_map(|t| {
                    let m = &t["topic_metadata"];
                    Some((
                        m["name"].as_str()?.to_string(),
                        m["type"].as_str()?.to_string(),
                        t["message_count"].as_u64().unwrap_or(0) as usize,
                    ))
                })
                .collect()
        })
        .unwrap_or_default();
    Ok(FolderInfo {
        storage,
        files,
        topics,
    })
}

/// Each storage file `metadata.yaml` (at `file`) names is a plain name of a regular file
/// inside the bag's folder `dir`, or missing (said where it is opened).
fn storage_files_inside(dir: &Path, file: &Path, files: &[String]) -> Result<(), BagError> {
    // Only plain names of regular files inside the folder: a metadata.yaml naming
    // `/dev/zero`, `../other.mcap` or `/etc/passwd` must not have them read.
    for f in files {
        let plain = std::path::Path::new(f)
            .components()
            .all(|c| matches!(c, std::path::Component::Normal(_)));
        if !plain || f.is_empty() {
            return Err(bad(
                file,
                format!("relative_file_paths: `{f}`: expected the name of a file inside the bag's folder (no absolute path, no `..`)"),
            ));
        }
        let path = dir.join(f);
        match std::fs::symlink_metadata(&path) {
            Ok(m) if m.is_file() => {}
            Ok(_) => {
                return Err(bad(
                    file,
                    format!("relative_file_paths: `{f}` is not a regular file in the bag's folder"),
                ))
            }
            Err(_) => {} // missing: said where the storage file is opened
        }
    }
    Ok(())
}

fn read_file(
    path: &Path,
    storage: Storage,
    topics: &mut BTreeMap<String, Topic>,
    budget: &mut Budget,
) -> Result<(), BagError> {
    let meta = std::fs::metadata(path).map_err(|source| BagError::Io {
        path: path.to_owned(),
        source,
    })?;
    // A device or a pipe (a symlink to /dev/zero named `.mcap`) has no length to check
    // and no end: only a regular file is read.
    if !meta.is_file() {
        return Err(bad(
            path,
            "not a regular file (a device, a pipe or a folder): expected a bag file",
        ));
    }
    let len = meta.len();
    if len > MAX_BAG_BYTES {
        return Err(bad(
            path,
            format!(
                "{len} bytes, more than the {MAX_BAG_BYTES} read whole; cut the log to the test first (`ros2 bag convert` with a time window)"
            ),
        ));
    }
    match storage {
        Storage::Mcap => super::mcap::read(path, topics, budget),
        Storage::Sqlite3 => super::sqlite::read(path, topics, budget),
        Storage::Rosbag1 => {
            let buf = std::fs::read(path).map_err(|source| BagError::Io {
                path: path.to_owned(),
                source,
            })?;
            crate::import::ros1::read(path, &buf, topics, budget)
        }
    }
}
