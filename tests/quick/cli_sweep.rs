//! `drive-sim sweep` and `drive-sim sweep-merge` end to end through the binary: a tiny matrix
//! (1 robot × 2 terrains × 1 sampler × 1 seed × 5 steps), resume, shards and their merge.

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

const MATRIX: &str = r#"
name = "tiny"
robots = ["warthog"]
terrains = ["asphalt", "ice"]
samplers = ["uniform-wheel"]
seeds = [3]
steps = 5
[options]
noise = "off"
"#;

/// The batch systems' index variables: cleared for every command, so that the tests run the
/// same inside a CI job that happens to be an array task.
const BATCH_VARS: [&str; 6] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_STEP",
    "SLURM_ARRAY_TASK_COUNT",
    "JOB_COMPLETION_INDEX",
    "AWS_BATCH_JOB_ARRAY_INDEX",
];

fn drive_sim_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_drive-sim"));
    for v in BATCH_VARS {
        c.env_remove(v);
    }
    c.args(args)
        .envs(env.iter().copied())
        .output()
        .expect("drive-sim runs")
}

fn drive_sim(args: &[&str]) -> Output {
    drive_sim_env(args, &[])
}

fn ok(o: &Output) -> String {
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout).to_string(),
        String::from_utf8_lossy(&o.stderr).to_string(),
    );
    assert!(o.status.success(), "stdout: {out}\nstderr: {err}");
    out
}

fn read_json(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn sweep_runs_resumes_shards_and_merges() {
    let tmp = tempfile::tempdir().unwrap();
    let matrix = tmp.path().join("tiny.toml");
    std::fs::write(&matrix, MATRIX).unwrap();
    let m = matrix.to_str().unwrap();

    // Whole sweep in one directory.
    let all = tmp.path().join("all");
    let out = ok(&drive_sim(&[
        "sweep",
        m,
        "--out",
        all.to_str().unwrap(),
        "--threads",
        "2",
    ]));
    assert!(out.contains("2 done, 0 skipped"), "{out}");
    for terrain in ["asphalt", "ice"] {
        let id = format!("warthog-{terrain}-uniform-wheel-s3");
        let done = read_json(&all.join(&id).join("done.json"));
        let r = &done["result"];
        assert_eq!(r["steps_analysed"], 5, "{r}");
        let rho = r["median_rho"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&rho), "{rho}");
        let te = r["time_efficiency"].as_f64().unwrap();
        assert!(te > 0.0 && te <= 1.0, "{te}");
        assert!(r["real_time_factor"].as_f64().unwrap() > 1.0);
        // 5 productive steps of 6 s: the simulated time is at least 30 s.
        assert!(r["simulated_s"].as_f64().unwrap() >= 30.0);
        assert_eq!(&read_json(&all.join(&id).join("run.json")), r);
    }
    // Ice is less predictable than asphalt, even over 5 steps.
    let rho = |t: &str| {
        read_json(
            &all.join(format!("warthog-{t}-uniform-wheel-s3"))
                .join("done.json"),
        )["result"]["median_rho"]
            .as_f64()
            .unwrap()
    };
    assert!(
        rho("ice") > rho("asphalt"),
        "{} vs {}",
        rho("ice"),
        rho("asphalt")
    );

    // Resume: nothing left to do.
    let out = ok(&drive_sim(&["sweep", m, "--out", all.to_str().unwrap()]));
    assert!(out.contains("0 done, 2 skipped"), "{out}");

    // Two shards, then their merge equals the single directory's runs.
    let s0 = tmp.path().join("s0");
    let s1 = tmp.path().join("s1");
    for (i, d) in [(0, &s0), (1, &s1)] {
        let out = ok(&drive_sim(&[
            "sweep",
            m,
            "--shard",
            &format!("{i}/2"),
            "--out",
            d.to_str().unwrap(),
        ]));
        assert!(out.contains("1 done, 0 skipped"), "{out}");
    }
    assert!(s0.join("warthog-asphalt-uniform-wheel-s3/done.json").exists());
    assert!(s1.join("warthog-ice-uniform-wheel-s3/done.json").exists());
    let merged_dir = tmp.path().join("merged");
    let out = ok(&drive_sim(&[
        "sweep-merge",
        s0.to_str().unwrap(),
        s1.to_str().unwrap(),
        "--out",
        merged_dir.to_str().unwrap(),
    ]));
    assert!(out.contains("2 runs merged"), "{out}");
    let merged = read_json(&merged_dir.join("merged.json"));
    let rows = merged["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(merged["missing"].as_array().unwrap().len(), 0);
    // The same seed gives the same run in a shard as in the whole sweep (deterministic).
    assert_eq!(rows[0]["terrain"], "asphalt");
    assert_eq!(rows[0]["median_rho"].as_f64().unwrap(), rho("asphalt"));
    assert_eq!(rows[1]["median_rho"].as_f64().unwrap(), rho("ice"));
    let csv = std::fs::read_to_string(merged_dir.join("merged.csv")).unwrap();
    assert!(csv.lines().next().unwrap().contains("median_rho"), "{csv}");
    assert_eq!(csv.lines().count(), 3);

    // Merging one shard alone reports the other's run as missing.
    let out = ok(&drive_sim(&[
        "sweep-merge",
        s0.to_str().unwrap(),
        "--out",
        tmp.path().join("half").to_str().unwrap(),
    ]));
    assert!(
        out.contains("1 runs missing: warthog-ice-uniform-wheel-s3"),
        "{out}"
    );
}

#[test]
fn sweep_reports_bad_inputs() {
    let tmp = tempfile::tempdir().unwrap();
    let bad = tmp.path().join("bad.toml");
    std::fs::write(&bad, MATRIX.replace("\"ice\"", "\"lava\"")).unwrap();
    let o = drive_sim(&[
        "sweep",
        bad.to_str().unwrap(),
        "--out",
        tmp.path().join("o").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("lava") && err.contains("terrains[1]"), "{err}");

    let noise = tmp.path().join("noise.toml");
    std::fs::write(&noise, MATRIX.replace("noise = \"off\"", "noise = \"loud\"")).unwrap();
    let o = drive_sim(&[
        "sweep",
        noise.to_str().unwrap(),
        "--out",
        tmp.path().join("n").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    // Refused before any run starts (bad input: exit code 2).
    assert!(
        text.contains("options.noise") && o.status.code() == Some(2),
        "{text}"
    );
    assert!(!tmp.path().join("n").exists(), "{text}");

    let o = drive_sim(&["sweep-merge", tmp.path().join("nothing").to_str().unwrap()]);
    assert!(!o.status.success());
}

#[test]
fn sweep_takes_its_shard_from_the_batch_system_and_keeps_logs() {
    let tmp = tempfile::tempdir().unwrap();
    let matrix = tmp.path().join("tiny.toml");
    std::fs::write(&matrix, MATRIX).unwrap();
    let m = matrix.to_str().unwrap();
    let (k0, k1) = (tmp.path().join("k0"), tmp.path().join("k1"));
    // A Kubernetes Indexed Job of two pods: index from JOB_COMPLETION_INDEX, count from the option.
    for (i, dir) in [("0", &k0), ("1", &k1)] {
        let o = drive_sim_env(
            &[
                "sweep",
                m,
                "--shard-count",
                "2",
                "--keep-logs",
                "--out",
                dir.to_str().unwrap(),
            ],
            &[("JOB_COMPLETION_INDEX", i)],
        );
        let out = ok(&o);
        assert!(out.contains("1 done, 0 skipped"), "{out}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(&format!(
                "shard {i}/2 from Kubernetes Indexed Job (JOB_COMPLETION_INDEX={i})"
            )),
            "{err}"
        );
    }
    let id = "warthog-ice-uniform-wheel-s3";
    let log = k1.join(id).join(format!("{id}.mcap"));
    assert!(log.exists(), "no kept log at {}", log.display());
    assert_eq!(
        read_json(&k1.join(id).join("run.json"))["log"],
        format!("{id}.mcap")
    );
    // The kept log is a complete drive-sim log: `analyze` reads it.
    let a = drive_sim(&[
        "analyze",
        log.to_str().unwrap(),
        "--out",
        tmp.path().join("a").to_str().unwrap(),
    ]);
    ok(&a);

    // SLURM with a task index out of the array's range, and two systems that disagree: errors
    // before any run.
    let o = drive_sim_env(
        &["sweep", m, "--out", tmp.path().join("x").to_str().unwrap()],
        &[("SLURM_ARRAY_TASK_ID", "2"), ("SLURM_ARRAY_TASK_COUNT", "2")],
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("out of range for 2 shards"), "{err}");
    let o = drive_sim_env(
        &[
            "sweep",
            m,
            "--shard-count",
            "2",
            "--out",
            tmp.path().join("y").to_str().unwrap(),
        ],
        &[("SLURM_ARRAY_TASK_ID", "0"), ("AWS_BATCH_JOB_ARRAY_INDEX", "1")],
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("SLURM job array says shard 0/2") && err.contains("shard 1/2"),
        "{err}"
    );
    assert!(!tmp.path().join("y").exists() || std::fs::read_dir(tmp.path().join("y")).unwrap().count() == 0);

    // A run done in two directories is reported by the merge, kept once.
    let k1b = tmp.path().join("k1b");
    ok(&drive_sim(&[
        "sweep",
        m,
        "--shard",
        "1/2",
        "--out",
        k1b.to_str().unwrap(),
    ]));
    let out = ok(&drive_sim(&[
        "sweep-merge",
        k0.to_str().unwrap(),
        k1.to_str().unwrap(),
        k1b.to_str().unwrap(),
        "--out",
        tmp.path().join("merged").to_str().unwrap(),
    ]));
    assert!(
        out.contains("2 runs merged") && out.contains("1 runs done more than once"),
        "{out}"
    );
    assert!(out.contains(id), "{out}");
}
