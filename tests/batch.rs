//! Past one machine: shards as separate processes with each scheduler's variables set as
//! that scheduler sets them (`--shard auto`), merged to the same bytes as one unsharded
//! run, for sweeps and for a batch of recordings interrupted and resumed; and the deploy
//! templates name what the code reads and parse.

mod common;
use common::tmp;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn agvsim() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_agvsim"));
    // A scheduler's variables in the test's own environment must not leak into a shard.
    for v in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_MAX",
        "SLURM_ARRAY_TASK_STEP",
        "SLURM_ARRAY_TASK_COUNT",
        "JOB_COMPLETION_INDEX",
        "AWS_BATCH_JOB_ARRAY_INDEX",
        "AWS_BATCH_JOB_ARRAY_SIZE",
        "AGVSIM_SHARD_INDEX",
        "AGVSIM_SHARD_COUNT",
    ] {
        c.env_remove(v);
    }
    c
}

fn ok(o: Output) -> String {
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{text}");
    text
}

/// Each scheduler's variables for shard `i` (0-based) of 3, as it sets them: Slurm
/// `--array=5-7` (1-based from 5), a Kubernetes Indexed Job of 3 completions (0-based,
/// the count from the template's AGVSIM_SHARD_COUNT), an AWS Batch array of size 3.
fn scheduler_env(i: usize) -> Vec<(&'static str, String)> {
    match i {
        0 => vec![
            ("SLURM_ARRAY_TASK_ID", "5".into()),
            ("SLURM_ARRAY_TASK_MIN", "5".into()),
            ("SLURM_ARRAY_TASK_MAX", "7".into()),
            ("SLURM_ARRAY_TASK_COUNT", "3".into()),
        ],
        1 => vec![
            ("JOB_COMPLETION_INDEX", "1".into()),
            ("AGVSIM_SHARD_COUNT", "3".into()),
        ],
        _ => vec![
            ("AWS_BATCH_JOB_ARRAY_INDEX", "2".into()),
            ("AWS_BATCH_JOB_ARRAY_SIZE", "3".into()),
        ],
    }
}

#[test]
fn a_sweep_sharded_by_each_schedulers_variables_merges_to_the_unsharded_bytes() {
    let dir = tmp("sweep");
    let sweep = |out: &str, env: &[(&str, String)]| {
        let mut c = agvsim();
        c.args([
            "sweep",
            "scenes/lab_offset_120mm.toml",
            "--vary",
            "controller.gain_scale=0.5..2:3",
            "--vary",
            "tyre.compound=hard_polyurethane,soft_rubber",
            "--duration",
            "1",
            "--jobs",
            "1",
        ]);
        if !env.is_empty() {
            c.args(["--shard", "auto"]);
        }
        c.envs(env.iter().map(|(k, v)| (k, v)));
        ok(c.arg("--out").arg(dir.join(out)).output().unwrap())
    };
    sweep("whole", &[]);
    for i in 0..3 {
        let said = sweep(&format!("s{i}"), &scheduler_env(i));
        assert!(said.contains(&format!("shard {}/3", i + 1)), "{said}");
    }
    ok(agvsim()
        .args(["sweep", "merge"])
        .args((0..3).rev().map(|i| dir.join(format!("s{i}"))))
        .arg("--out")
        .arg(dir.join("merged"))
        .output()
        .unwrap());
    assert_eq!(
        std::fs::read(dir.join("whole/results.csv")).unwrap(),
        std::fs::read(dir.join("merged/results.csv")).unwrap()
    );
    // A contradictory set is refused, naming both.
    let mut c = agvsim();
    c.args([
        "sweep",
        "scenes/lab_offset_120mm.toml",
        "--vary",
        "controller.gain_scale=1,2",
        "--shard",
        "auto",
    ])
    .envs(scheduler_env(0).into_iter().chain(scheduler_env(1)))
    .arg("--out")
    .arg(dir.join("bad"));
    let o = c.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("disagree") && err.contains("SLURM_ARRAY_TASK_ID"),
        "{err}"
    );
}

/// 20 recordings: the development set's 11 drive axes and 9 the simulator made with
/// concealed effects (`prove --quick`, three seeds), each with its rig beside it.
fn fleet(dir: &Path) -> PathBuf {
    let fleet = dir.join("fleet");
    std::fs::create_dir_all(&fleet).unwrap();
    for i in 1..=11 {
        for ext in ["csv", "rig.toml"] {
            let name = format!("dev_axis_{i:02}.{ext}");
            std::fs::copy(
                Path::new("../shared/data/dev").join(&name),
                fleet.join(&name),
            )
            .unwrap();
        }
    }
    for seed in 1..=3 {
        let made = dir.join(format!("prove{seed}"));
        ok(agvsim()
            .args(["prove", "--quick", "--seed", &seed.to_string(), "--out"])
            .arg(&made)
            .output()
            .unwrap());
        for case in ["clean", "coulomb_friction", "voltage_saturation"] {
            for ext in ["csv", "rig.toml"] {
                std::fs::copy(
                    made.join(format!("prove_{case}.{ext}")),
                    fleet.join(format!("sim_{case}_seed{seed}.{ext}")),
                )
                .unwrap();
            }
        }
    }
    fleet
}

const EFFECTS: &str = "coulomb_friction,backlash,voltage_saturation";

fn batch(fleet: &Path, out: &Path, env: &[(&str, String)]) -> Command {
    let mut c = agvsim();
    c.args(["batch", "diagnose"])
        .arg(fleet)
        .args(["--effects", EFFECTS, "--out"])
        .arg(out);
    if !env.is_empty() {
        c.args(["--shard", "auto"]);
    }
    c.envs(env.iter().map(|(k, v)| (k, v)));
    c
}

fn results(out: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(out.join("results"))
        .map(|d| d.map(|e| e.unwrap().path()).collect())
        .unwrap_or_default();
    v.retain(|p| p.extension().is_some_and(|x| x == "json"));
    v
}

#[test]
fn a_fleet_sharded_three_ways_interrupted_and_resumed_merges_to_the_uninterrupted_summary() {
    let dir = tmp("fleet");
    let fleet = fleet(&dir);
    let whole = dir.join("whole");
    let said = ok(batch(&fleet, &whole, &[]).output().unwrap());
    assert!(said.contains("20 of 20 recordings"), "{said}");
    assert!(said.contains("20 computed, 0 kept"), "{said}");

    // Shard 2 is killed once it has written a result, then run again.
    let s1 = dir.join("s1");
    let mut child = batch(&fleet, &s1, &scheduler_env(1))
        .arg("--jobs")
        .arg("1")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while results(&s1).is_empty() && t0.elapsed().as_secs() < 300 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let done = results(&s1);
    assert!(
        !done.is_empty() && done.len() < 7,
        "{} results before the kill",
        done.len()
    );
    // Whatever the kill caught, every result on disk is whole.
    for p in &done {
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(p).unwrap())
            .unwrap_or_else(|e| panic!("{} half-written: {e}", p.display()));
        assert_eq!(v["status"], "ok", "{}", p.display());
    }
    for i in 0..3 {
        let out = dir.join(format!("s{i}"));
        let said = ok(batch(&fleet, &out, &scheduler_env(i)).output().unwrap());
        assert!(said.contains(&format!("shard {}/3", i + 1)), "{said}");
        if i == 1 {
            assert!(
                said.contains(&format!("{} kept from an earlier run", done.len())),
                "{said}"
            );
        }
    }
    let merged = dir.join("merged");
    ok(agvsim()
        .args(["batch", "merge"])
        .args((0..3).map(|i| dir.join(format!("s{i}"))))
        .arg("--out")
        .arg(&merged)
        .output()
        .unwrap());
    for f in ["summary.csv", "fleet.md"] {
        assert_eq!(
            std::fs::read_to_string(whole.join(f)).unwrap(),
            std::fs::read_to_string(merged.join(f)).unwrap(),
            "{f}"
        );
    }
    // The summary names what the simulator concealed: Coulomb friction in each seed's
    // record of it, and the clean records clean.
    let summary = std::fs::read_to_string(whole.join("summary.csv")).unwrap();
    for seed in 1..=3 {
        let row = |case: &str| {
            summary
                .lines()
                .find(|l| l.starts_with(&format!("sim_{case}_seed{seed}.csv,")))
                .unwrap()
                .to_string()
        };
        assert!(
            row("coulomb_friction").contains(",coulomb_friction "),
            "{}",
            row("coulomb_friction")
        );
        assert!(
            row("clean").starts_with(&format!("sim_clean_seed{seed}.csv,ok,")),
            "{}",
            row("clean")
        );
        assert!(
            !row("clean").contains("coulomb_friction"),
            "{}",
            row("clean")
        );
    }
    let fleet_md = std::fs::read_to_string(whole.join("fleet.md")).unwrap();
    assert!(
        fleet_md.contains("20 recordings, 20 with a result"),
        "{fleet_md}"
    );
}

#[test]
fn the_deploy_templates_parse_and_name_the_variables_the_code_reads() {
    let sbatch = std::fs::read_to_string("deploy/slurm/batch.sbatch").unwrap();
    assert!(
        sbatch.contains("--shard auto") && sbatch.contains("--array="),
        "{sbatch}"
    );
    for script in [
        "deploy/slurm/batch.sbatch",
        "deploy/slurm/merge.sbatch",
        "deploy/slurm/submit.sh",
    ] {
        let o = Command::new("bash").args(["-n", script]).output().unwrap();
        assert!(
            o.status.success(),
            "{script}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    // Kubernetes: YAML that parses, an Indexed Job whose completions is the count the
    // code reads from AGVSIM_SHARD_COUNT.
    let k8s = std::fs::read_to_string("deploy/kubernetes/batch-job.yaml").unwrap();
    let docs: Vec<serde_yaml::Value> = serde_yaml::Deserializer::from_str(&k8s)
        .map(|d| serde::Deserialize::deserialize(d).unwrap())
        .collect();
    let job = docs
        .iter()
        .find(|d| d["spec"]["completionMode"] == "Indexed")
        .expect("an Indexed Job");
    let completions = job["spec"]["completions"].as_u64().unwrap();
    let container = &job["spec"]["template"]["spec"]["containers"][0];
    let env = container["env"].as_sequence().unwrap();
    let count = env
        .iter()
        .find(|e| e["name"] == "AGVSIM_SHARD_COUNT")
        .expect("AGVSIM_SHARD_COUNT set");
    assert_eq!(count["value"].as_str().unwrap(), completions.to_string());
    let args: Vec<String> = container["args"]
        .as_sequence()
        .unwrap()
        .iter()
        .map(|a| a.as_str().unwrap().to_string())
        .collect();
    assert!(
        args.windows(2).any(|w| w == ["--shard", "auto"]),
        "{args:?}"
    );
    assert!(docs.iter().any(|d| d["metadata"]["name"] == "agvsim-merge"));
    // AWS Batch: JSON job definitions; the array job reads AWS_BATCH_JOB_ARRAY_INDEX and
    // the size the code reads.
    let aws: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string("deploy/aws-batch/job-definition.json").unwrap(),
    )
    .unwrap();
    let cmd: Vec<&str> = aws["containerProperties"]["command"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_str().unwrap())
        .collect();
    assert!(cmd.windows(2).any(|w| w == ["--shard", "auto"]), "{cmd:?}");
    let submit = std::fs::read_to_string("deploy/aws-batch/submit.sh").unwrap();
    assert!(
        submit.contains("AGVSIM_SHARD_COUNT") && submit.contains("--depends-on"),
        "{submit}"
    );
    let o = Command::new("bash")
        .args(["-n", "deploy/aws-batch/submit.sh"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}
