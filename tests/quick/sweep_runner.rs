//! Sweep runner: expansion, sharding, resume, merge, and errors on bad matrix files, with a
//! fake run callback.

use drive_sim::harness::sweep::{
    merge, run_sweep, RunOptions, RunOutcome, RunSpec, Shard, SweepMatrix, DONE_FILE,
};
use drive_sim::harness::Error;
use serde_json::{json, Value};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

const MATRIX: &str = r#"
name = "t"
robots = ["warthog", "husky"]
terrains = ["ice", "asphalt", "mud"]
samplers = ["uniform-wheel", "halton"]
seeds = [1, 2, 3, 4]
steps = 20
[protocol]
border_margin_m = 0.7
[options]
dt_s = 0.002
"#;

fn matrix() -> SweepMatrix {
    SweepMatrix::parse(MATRIX, Path::new("t.toml")).unwrap()
}

/// A fake run: writes a file, returns figures computed from the spec.
fn fake(spec: &RunSpec, dir: &Path) -> drive_sim::harness::Result<Value> {
    std::fs::write(dir.join("log.txt"), &spec.id).unwrap();
    Ok(json!({
        "rho": {"median": spec.seed as f64 / 10.0},
        "interruptions": spec.index % 5,
        "tag": format!("{}/{}", spec.robot, spec.sampler),
    }))
}

fn opts(dir: &Path, shard: Shard) -> RunOptions {
    RunOptions {
        out_dir: dir.to_path_buf(),
        shard,
        threads: Some(2),
    }
}

#[test]
fn expansion_counts_orders_and_names_runs() {
    let m = matrix();
    let specs = m.expand();
    // 2 robots x 3 terrains x 2 samplers x 4 seeds.
    assert_eq!(specs.len(), 48);
    assert_eq!(m.len(), 48);
    assert!(specs.iter().enumerate().all(|(i, s)| s.index == i));
    assert_eq!(specs[0].id, "warthog-ice-uniform-wheel-s1");
    assert_eq!(specs[3].id, "warthog-ice-uniform-wheel-s4");
    assert_eq!(specs[4].id, "warthog-ice-halton-s1");
    assert_eq!(specs[47].id, "husky-mud-halton-s4");
    let ids: BTreeSet<&str> = specs.iter().map(|s| s.id.as_str()).collect();
    assert_eq!(ids.len(), 48);
    // Run options reach every spec.
    assert!(specs.iter().all(|s| s.protocol.steps == 20
        && s.protocol.border_margin_m == 0.7
        && s.protocol.rate_hz == 20.0
        && s.options["dt_s"] == json!(0.002)));
    // The same file gives the same specs.
    assert_eq!(specs, matrix().expand());
}

#[test]
fn shards_partition_the_runs() {
    let m = matrix();
    let all: Vec<String> = m.expand().into_iter().map(|s| s.id).collect();
    for n in [1, 2, 5, 48, 50] {
        let mut seen: Vec<String> = Vec::new();
        for i in 0..n {
            let part = m.shard(Shard::new(i, n).unwrap());
            assert!(part.iter().all(|s| s.index % n == i));
            seen.extend(part.into_iter().map(|s| s.id));
        }
        let unique: BTreeSet<&String> = seen.iter().collect();
        assert_eq!(seen.len(), all.len(), "n = {n}: a run in two shards");
        assert_eq!(unique, all.iter().collect(), "n = {n}: a run in no shard");
    }
    assert_eq!("1/4".parse::<Shard>().unwrap(), Shard::new(1, 4).unwrap());
    for bad in ["4/4", "1", "a/2", "0/0", "-1/2"] {
        let msg = bad.parse::<Shard>().unwrap_err().to_string();
        assert!(msg.contains("--shard"), "{bad}: {msg}");
    }
}

#[test]
fn resume_skips_finished_runs_and_redoes_partial_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let m = matrix();
    let calls = AtomicUsize::new(0);
    // First invocation: runs with seed 3 fail, the others complete.
    let flaky = |spec: &RunSpec, dir: &Path| {
        calls.fetch_add(1, Ordering::SeqCst);
        if spec.seed == 3 {
            std::fs::write(dir.join("partial.txt"), "half").unwrap();
            return Err(Error::log(dir.join("partial.txt"), "run", "simulated failure"));
        }
        fake(spec, dir)
    };
    let r1 = run_sweep(&m, &opts(&out, Shard::default()), flaky).unwrap();
    assert_eq!(calls.load(Ordering::SeqCst), 48);
    assert_eq!((r1.done(), r1.skipped(), r1.failed()), (36, 0, 12));
    let failed = out.join("warthog-ice-halton-s3");
    assert!(failed.join("partial.txt").exists() && !failed.join(DONE_FILE).exists());
    // A run killed half-way leaves a directory without marker: redone too.
    let killed = out.join("husky-mud-uniform-wheel-s1");
    std::fs::remove_file(killed.join(DONE_FILE)).unwrap();
    // Second invocation: only the 12 failed runs and the killed one are called again, and the
    // partial files are gone.
    let calls2 = AtomicUsize::new(0);
    let counting = |spec: &RunSpec, dir: &Path| {
        calls2.fetch_add(1, Ordering::SeqCst);
        assert!(!dir.join("partial.txt").exists(), "partial output kept");
        fake(spec, dir)
    };
    let r2 = run_sweep(&m, &opts(&out, Shard::default()), counting).unwrap();
    assert_eq!(calls2.load(Ordering::SeqCst), 13);
    assert_eq!((r2.done(), r2.skipped(), r2.failed()), (13, 35, 0));
    // Third: nothing to do.
    let calls3 = AtomicUsize::new(0);
    let r3 = run_sweep(&m, &opts(&out, Shard::default()), |s: &RunSpec, d: &Path| {
        calls3.fetch_add(1, Ordering::SeqCst);
        fake(s, d)
    })
    .unwrap();
    assert_eq!(calls3.load(Ordering::SeqCst), 0);
    assert_eq!(r3.skipped(), 48);
    // Changing a run option makes the old markers stale: everything runs again.
    let mut m2 = m.clone();
    m2.steps = 30;
    let calls4 = AtomicUsize::new(0);
    run_sweep(&m2, &opts(&out, Shard::default()), |s: &RunSpec, d: &Path| {
        calls4.fetch_add(1, Ordering::SeqCst);
        fake(s, d)
    })
    .unwrap();
    assert_eq!(calls4.load(Ordering::SeqCst), 48);
}

#[test]
fn a_panicking_run_fails_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let m = matrix();
    let r = run_sweep(
        &m,
        &opts(tmp.path(), Shard::new(0, 8).unwrap()),
        |s: &RunSpec, d: &Path| {
            if s.index == 8 {
                panic!("rapier exploded");
            }
            fake(s, d)
        },
    )
    .unwrap();
    assert_eq!(r.outcomes.len(), 6);
    assert_eq!(r.failed(), 1);
    let f = r
        .outcomes
        .iter()
        .find(|o| matches!(o, RunOutcome::Failed { .. }))
        .unwrap();
    assert_eq!(f.id(), m.expand()[8].id);
    match f {
        RunOutcome::Failed { message, .. } => assert!(message.contains("rapier exploded")),
        _ => unreachable!(),
    }
}

#[test]
fn merged_shards_equal_the_unsharded_sweep() {
    let tmp = tempfile::tempdir().unwrap();
    let m = matrix();
    let whole = tmp.path().join("whole");
    let shards: Vec<PathBuf> = (0..2).map(|i| tmp.path().join(format!("shard{i}"))).collect();
    run_sweep(&m, &opts(&whole, Shard::default()), fake).unwrap();
    for (i, dir) in shards.iter().enumerate() {
        let r = run_sweep(&m, &opts(dir, Shard::new(i, 2).unwrap()), fake).unwrap();
        assert_eq!(r.done(), 24);
    }
    let a = merge(std::slice::from_ref(&whole)).unwrap();
    let b = merge(&shards).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.rows.len(), 48);
    assert!(a.missing.is_empty());
    assert_eq!(
        a.columns,
        [
            "index",
            "id",
            "robot",
            "terrain",
            "sampler",
            "seed",
            "steps",
            "interruptions",
            "rho.median",
            "tag"
        ]
    );
    // Row 5 is warthog-ice-halton-s2: rho 0.2, interruptions 5 % 5 = 0.
    let r5 = &a.rows[5];
    assert_eq!(r5["id"], json!("warthog-ice-halton-s2"));
    assert_eq!(r5["rho.median"], json!(0.2));
    assert_eq!(r5["interruptions"], json!(0));
    // The CSV has a header and one line per run; merging a shard alone lists what is missing.
    let csv = a.to_csv().unwrap();
    assert_eq!(csv.lines().count(), 49);
    assert!(csv
        .lines()
        .nth(6)
        .unwrap()
        .starts_with("5,warthog-ice-halton-s2,warthog,ice,halton,2,20,0,0.2,warthog/halton"));
    let half = merge(&shards[..1]).unwrap();
    assert_eq!(half.rows.len(), 24);
    assert_eq!(half.missing.len(), 24);
    assert!(half.missing.contains(&"warthog-ice-uniform-wheel-s2".to_string()));
    let (json_path, csv_path) = a.write(&tmp.path().join("merged")).unwrap();
    assert_eq!(std::fs::read_to_string(csv_path).unwrap(), csv);
    let back: drive_sim::harness::sweep::MergedReport =
        serde_json::from_str(&std::fs::read_to_string(json_path).unwrap()).unwrap();
    assert_eq!(back, a);
}

#[test]
fn merge_reports_runs_done_twice_and_refuses_conflicting_parameters() {
    let tmp = tempfile::tempdir().unwrap();
    let m = matrix();
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    run_sweep(&m, &opts(&a, Shard::new(0, 4).unwrap()), fake).unwrap();
    // The same shard again elsewhere: figures that differ (like a wall time) are still the
    // same runs, done twice.
    run_sweep(
        &m,
        &opts(&b, Shard::new(0, 4).unwrap()),
        |s: &RunSpec, d: &Path| {
            let mut v = fake(s, d)?;
            v["tag"] = json!("other");
            Ok(v)
        },
    )
    .unwrap();
    let merged = merge(&[a.clone(), b.clone()]).unwrap();
    assert_eq!(merged.rows.len(), 12);
    assert_eq!(merged.duplicates.len(), 12);
    let d = &merged.duplicates[0];
    assert_eq!(d.dirs.len(), 2);
    assert!(d.dirs[0].starts_with(&a) && d.dirs[1].starts_with(&b), "{d:?}");
    // The first directory's figures are kept.
    assert!(merged.rows.iter().all(|r| r["tag"] != json!("other")));
    // A run of the same id with other parameters is not the same run: the merge refuses.
    let c = tmp.path().join("c");
    let other = SweepMatrix::parse(
        &MATRIX.replace("border_margin_m = 0.7", "border_margin_m = 0.9"),
        Path::new("t.toml"),
    )
    .unwrap();
    run_sweep(&other, &opts(&c, Shard::new(0, 4).unwrap()), fake).unwrap();
    let msg = merge(&[a, c]).unwrap_err().to_string();
    assert!(msg.contains("other parameters") && msg.contains("-s1`"), "{msg}");
    assert!(msg.contains("/a/") && msg.contains("/c/"), "{msg}");
}

/// A sweep split across the tasks of a batch array, each taking its shard from the
/// environment as the scheduler sets it, runs every run exactly once, and the shards merge
/// into the whole sweep.
#[test]
fn a_sweep_split_across_batch_tasks_runs_every_run_once_and_merges() {
    use drive_sim::harness::sweep::{select_shard, ShardSource};
    let tmp = tempfile::tempdir().unwrap();
    let m = matrix();
    let calls = AtomicUsize::new(0);
    let seen = std::sync::Mutex::new(Vec::new());
    let counting = |spec: &RunSpec, dir: &Path| {
        calls.fetch_add(1, Ordering::SeqCst);
        seen.lock().unwrap().push(spec.id.clone());
        fake(spec, dir)
    };
    // SLURM: --array=1-9:2 gives task ids 1, 3, 5, 7, 9 (min 1, step 2, count 5).
    let mut dirs = Vec::new();
    for id in [1, 3, 5, 7, 9] {
        let env = move |name: &str| match name {
            "SLURM_ARRAY_TASK_ID" => Some(id.to_string()),
            "SLURM_ARRAY_TASK_MIN" => Some("1".into()),
            "SLURM_ARRAY_TASK_STEP" => Some("2".into()),
            "SLURM_ARRAY_TASK_COUNT" => Some("5".into()),
            _ => None,
        };
        let choice = select_shard(None, None, &env).unwrap();
        assert_eq!(choice.source, ShardSource::Slurm);
        assert_eq!(choice.shard, Shard::new((id - 1) / 2, 5).unwrap());
        let dir = tmp.path().join(format!("slurm-{id}"));
        run_sweep(&m, &opts(&dir, choice.shard), counting).unwrap();
        dirs.push(dir);
    }
    assert_eq!(calls.load(Ordering::SeqCst), m.len());
    let ids: BTreeSet<String> = seen.lock().unwrap().iter().cloned().collect();
    assert_eq!(ids.len(), m.len(), "a run was done twice");
    let merged = merge(&dirs).unwrap();
    assert_eq!(merged.rows.len(), m.len());
    assert!(merged.missing.is_empty() && merged.duplicates.is_empty());
    let whole = tmp.path().join("whole");
    run_sweep(&m, &opts(&whole, Shard::default()), fake).unwrap();
    assert_eq!(merged.rows, merge(&[whole]).unwrap().rows);

    // Kubernetes and AWS Batch: the index from the environment, the count from --shard-count.
    for (var, source) in [
        ("JOB_COMPLETION_INDEX", ShardSource::Kubernetes),
        ("AWS_BATCH_JOB_ARRAY_INDEX", ShardSource::AwsBatch),
    ] {
        let mut dirs = Vec::new();
        for i in 0..3 {
            let env = move |name: &str| (name == var).then(|| i.to_string());
            let choice = select_shard(None, Some(3), &env).unwrap();
            assert_eq!(
                (choice.shard, &choice.source),
                (Shard::new(i, 3).unwrap(), &source)
            );
            let dir = tmp.path().join(format!("{var}-{i}"));
            run_sweep(&m, &opts(&dir, choice.shard), fake).unwrap();
            dirs.push(dir);
        }
        let merged = merge(&dirs).unwrap();
        assert_eq!(merged.rows.len(), m.len());
        assert!(merged.missing.is_empty() && merged.duplicates.is_empty());
        // An index at the count is refused before any run.
        let env = move |name: &str| (name == var).then(|| "3".to_string());
        let e = select_shard(None, Some(3), &env).unwrap_err().to_string();
        assert!(e.contains("out of range for 3 shards"), "{e}");
    }
}

/// The field named by a config error.
fn field_of(text: &str) -> String {
    match SweepMatrix::parse(text, Path::new("bad.toml")).unwrap_err() {
        Error::Model(drive_sim::Error::Config { field, file, .. }) => {
            assert_eq!(file, Path::new("bad.toml"));
            field
        }
        e => panic!("not a config error: {e}"),
    }
}

#[test]
fn bad_matrix_files_name_the_field() {
    assert_eq!(field_of(&MATRIX.replace("steps = 20", "steps = 0")), "steps");
    assert_eq!(field_of(&MATRIX.replace("steps = 20\n", "")), "(top level)");
    assert!(
        SweepMatrix::parse(&MATRIX.replace("steps = 20\n", ""), Path::new("bad.toml"))
            .unwrap_err()
            .to_string()
            .contains("steps")
    );
    assert_eq!(
        field_of(&MATRIX.replace("\"halton\"", "\"sobol\"")),
        "samplers[1]"
    );
    assert_eq!(field_of(&MATRIX.replace("[1, 2, 3, 4]", "[1, 2, 2]")), "seeds[2]");
    assert_eq!(field_of(&MATRIX.replace("[1, 2, 3, 4]", "[1, -2]")), "seeds[1]");
    assert_eq!(field_of(&MATRIX.replace("[1, 2, 3, 4]", "[]")), "seeds");
    assert_eq!(
        field_of(&MATRIX.replace("steps = 20", "steps = \"many\"")),
        "steps"
    );
    assert_eq!(
        field_of(&MATRIX.replace("border_margin_m = 0.7", "border_margin_m = -1.0")),
        "protocol.border_margin_m"
    );
    assert_eq!(
        field_of(&MATRIX.replace("border_margin_m", "border_margn_m")),
        "protocol.border_margn_m"
    );
    assert_eq!(
        field_of(&MATRIX.replace("name = \"t\"", "name = \"a b\"")),
        "name"
    );
    assert_eq!(
        field_of(&MATRIX.replace("\"mud\"", "\"dir/ice.toml\"")),
        "terrains[2]"
    );
    let top = MATRIX.replace("steps = 20", "steps = 20\nstep = 20");
    assert_eq!(field_of(&top), "step");
    // Keys under [options] are free-form: accepted and passed on.
    let extra = SweepMatrix::parse(&format!("{MATRIX}\nfoo = 1"), Path::new("ok.toml")).unwrap();
    assert_eq!(extra.expand()[0].options["foo"], json!(1));
}

#[test]
fn unknown_robots_and_terrains_are_named_when_loading() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("m.toml");
    std::fs::write(&path, MATRIX.replace("\"husky\"", "\"tank\"")).unwrap();
    let err = SweepMatrix::load(&path).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("robots[1]") && msg.contains("tank") && msg.contains("m.toml"),
        "{msg}"
    );
    std::fs::write(&path, MATRIX.replace("\"mud\"", "\"lava\"")).unwrap();
    let msg = SweepMatrix::load(&path).unwrap_err().to_string();
    assert!(msg.contains("terrains[2]") && msg.contains("lava"), "{msg}");
    let msg = SweepMatrix::load(&tmp.path().join("none.toml"))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("none.toml"), "{msg}");
}

#[test]
fn the_example_matrix_loads() {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/sweeps/example.toml"));
    let m = SweepMatrix::load(path).unwrap();
    // 2 robots x 2 terrains x 3 samplers x 3 seeds.
    assert_eq!(m.expand().len(), 36);
    assert_eq!(
        m.expand()[0].protocol,
        drive_sim::protocol::ProtocolConfig {
            steps: 150,
            ..Default::default()
        }
    );
}

#[test]
fn a_protocol_sweep_on_the_ideal_plant_matches_direct_runs() {
    use drive_sim::protocol::sampler::make_sampler_for;
    use drive_sim::protocol::{run_drive, RunSummary};
    use drive_sim::robot::Robot;
    use drive_sim::sim::IdealPlant;
    let text = r#"
name = "ideal"
robots = ["husky"]
terrains = ["asphalt"]
samplers = ["uniform-wheel", "boundary-aware", "halton"]
seeds = [1, 2]
steps = 8
"#;
    let m = SweepMatrix::parse(text, Path::new("ideal.toml")).unwrap();
    // The lead's real callback simulates the terrain; the ideal plant ignores it.
    let simulate = |spec: &RunSpec| -> drive_sim::harness::Result<RunSummary> {
        let (robot, _) = Robot::resolve(&spec.robot)?;
        let mut plant = IdealPlant::new(robot.idd(), robot.powertrain.time_constant_s);
        let mut sampler = make_sampler_for(&spec.sampler, spec.seed, &spec.protocol)
            .ok_or_else(|| drive_sim::harness::unknown_sampler(&spec.sampler))?;
        let mut frames = Vec::new();
        Ok(run_drive(
            &mut plant,
            &robot,
            sampler.as_mut(),
            &spec.protocol,
            &mut frames,
        )?)
    };
    let tmp = tempfile::tempdir().unwrap();
    let report = run_sweep(
        &m,
        &opts(tmp.path(), Shard::default()),
        |s: &RunSpec, _: &Path| Ok(serde_json::to_value(simulate(s)?).unwrap()),
    )
    .unwrap();
    assert_eq!(report.done(), 6);
    let merged = merge(&[tmp.path().to_path_buf()]).unwrap();
    for (row, spec) in merged.rows.iter().zip(m.expand()) {
        let direct = simulate(&spec).unwrap();
        assert_eq!(row["id"], json!(spec.id));
        assert_eq!(row["interruptions"], json!(direct.interruptions));
        assert_eq!(row["total_time_s"], json!(direct.total_time_s));
        assert_eq!(row["steps_completed"], json!(8));
    }
}
