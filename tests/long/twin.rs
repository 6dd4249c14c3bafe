//! `drive-sim twin` on the independent generator (`tests/common/generator.rs`, not the
//! project's plants), whose answer is known:
//! - a run of a generator robot whose motors clip at 10 rad/s and whose body slips in turns
//!   gives a twin that `judge` cannot tell from the steps its choice never saw;
//! - that twin, judged on a run of the same robot on another ground (wider skid track, slower
//!   wheels, an earlier clip), fails, and so does the robot's own run; the yardstick test
//!   finds that twin no farther from there than the robot's run it was made from, and farther
//!   than the robot's second run on that ground;
//! - the command end to end writes the twin's files, which run with no other option, the
//!   held-out twin's, which judged again give the held-out verdict's losses, and a report that
//!   opens on the verdict;
//! - bad input (logs of two robots, a run too short to split, a run with no steady window, an
//!   unknown knob) exits with code 2 before any long work, naming the log and what is missing;
//! - a first round's accepted tuning is followed by a second round over the other knobs,
//!   screened from the tuned twin; the same run's steps scatter by 1.5 rad/s per wheel, and its
//!   twin carries an offset near it, measured on the steps and not searched; its pose, fresh at
//!   every sample, gives no update intervals.
//!
//! The runs are short (40 steps, 20 per half; 80 for the step offset, which needs a dozen pairs
//! of neighbouring steps), the search's budget a quarter of the default (half for the second
//! round, whose first round must be accepted) and each judgement 4 runs of the twin against 19
//! references; the full budget is `scripts/twin_results.py`'s, on the measured runs.

use crate::common;
use common::generator::{write_drive_mcap, TestRobotSpec, Unmodelled};
use drive_sim::calibration::twin::lift_effects;
use drive_sim::compare::judge::{judge, yardsticks, JudgeRequest, YardstickRequest};
use drive_sim::log::UseSteps;
use drive_sim::robot::Robot;
use drive_sim::terrain::Terrain;
use drive_sim::twin::{make_twin, Twin, TwinOptions, TwinRequest};
use std::path::Path;
use std::process::Command;

/// The generator's ground A: motors clipping at 10 rad/s, a centripetal slip.
fn ground_a() -> Unmodelled {
    Unmodelled {
        wheel_limit_rad_s: 10.0,
        centripetal_s: -0.20,
        pose_yaw_noise_rad: 0.01,
        ..Unmodelled::default()
    }
}

fn options() -> TwinOptions {
    TwinOptions {
        budget: 0.25,
        judge_sims: 4,
        ..TwinOptions::default()
    }
}

#[test]
fn a_twin_of_a_generator_run_passes_its_held_out_steps_and_is_told_from_another_ground() {
    let dir = tempfile::tempdir().unwrap();
    let run_a = dir.path().join("ground_a.mcap");
    write_drive_mcap(
        &run_a,
        "ground_a",
        "asphalt",
        TestRobotSpec::warthog_on_asphalt(3),
        ground_a(),
        40,
    );
    let out = dir.path().join("twin");
    let req = TwinRequest {
        logs: vec![run_a.clone()],
        out: out.clone(),
        input: Default::default(),
        options: options(),
        knobs: None,
    };
    let twin = make_twin(&req, &|e| eprintln!("{e}")).unwrap();
    let r = &twin.report;
    eprintln!("{}", r.answer);
    // Judged on the even steps, which played no part in choosing it.
    let held = &r.held_out.judgements[0];
    assert!(held.held_out && held.steps == "even");
    assert!(
        held.outcome.indistinguishable,
        "held out: p {}",
        held.outcome.loss.p
    );
    // A twin that passes needs no yardstick of the robot's own choosing steps.
    assert!(held.outcome.yardsticks.is_empty());
    // The generator's pose changes at every sample and its steps do not scatter: nothing is
    // measured to hold the pose, nor, beyond noise, to scatter the wheels.
    for pass in [&r.held_out.pass, &r.final_twin.pass] {
        eprintln!("measured: {:?}", pass.measured);
        assert!(
            !pass.measured.iter().any(|m| m.name.starts_with("pose_update")),
            "{:?}",
            pass.measured
        );
    }
    // The files: written, the report opening on the verdict, and a twin that runs with no
    // other option.
    for f in [
        "twin/robot.toml",
        "twin/terrain.toml",
        "held_out/robot.toml",
        "held_out/terrain.toml",
        "twin.json",
        "twin.md",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    // The held-out twin's files hold the model the judge ran on the even steps: judged again
    // with the same options, it gives the same losses to the bit.
    let first = drive_sim::log::read_log(&run_a).unwrap();
    let held_model = lift_effects(
        &Robot::resolve(out.join("held_out/robot.toml").to_str().unwrap())
            .unwrap()
            .0,
        &Terrain::resolve(out.join("held_out/terrain.toml").to_str().unwrap())
            .unwrap()
            .0,
    )
    .unwrap();
    let again = judge(
        &JudgeRequest {
            real: &first,
            model: &held_model,
            opts: &held.outcome.options,
        },
        &|_| {},
    )
    .unwrap();
    assert_eq!(again.loss.real, held.outcome.loss.real);
    assert_eq!(again.loss.references, held.outcome.loss.references);
    let md = std::fs::read_to_string(out.join("twin.md")).unwrap();
    let opening: Vec<&str> = md.lines().filter(|l| !l.trim().is_empty()).take(3).collect();
    assert!(
        opening[1].contains("Can compare tell the twin from the robot?"),
        "{opening:?}"
    );
    assert!(
        opening[2].contains("Held out") && opening[2].contains("tell the twin"),
        "{opening:?}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("twin.json")).unwrap()).unwrap();
    assert!(json["provenance"]["version"].is_string());
    assert!(json["final"]["pass"]["times"].as_array().unwrap().len() >= 3);
    // A tuning the check accepted is followed by a second round from the tuned twin, over the
    // knobs the first did not tune; its rule takes at most two.
    for pass in [&r.held_out.pass, &r.final_twin.pass] {
        let accepted = pass.tuning.as_ref().is_some_and(|t| t.accepted);
        assert_eq!(pass.refinement.is_some(), accepted, "{:?}", pass.choice.chosen);
        if let Some(rf) = &pass.refinement {
            assert_eq!(
                rf.screening.knobs.len() + pass.choice.chosen.len(),
                pass.screening.knobs.len()
            );
            assert!(rf
                .screening
                .knobs
                .iter()
                .all(|k| !pass.choice.chosen.contains(&k.knob.name)));
            assert!(rf.choice.chosen.len() <= 2);
        }
    }
    let robot = Robot::resolve(out.join("twin/robot.toml").to_str().unwrap())
        .unwrap()
        .0;
    let terrain = Terrain::resolve(out.join("twin/terrain.toml").to_str().unwrap())
        .unwrap()
        .0;
    let model = lift_effects(&robot, &terrain).unwrap();
    let ran = drive_sim::harness::simulate(
        &robot,
        &terrain,
        "uniform-wheel",
        20,
        5,
        drive_sim::sim::SensorNoise::typical(),
    )
    .unwrap();
    assert_eq!(ran.log.steps().len(), 20);
    // The same robot on another ground (wider skid track, slower wheels, an earlier clip): the
    // twin is told apart, and so is the robot's own run on ground A.
    let opts = options().judge_options(UseSteps::All);
    let other_ground = Unmodelled {
        wheel_limit_rad_s: 6.0,
        centripetal_s: 0.15,
        ..ground_a()
    };
    let spec_b = TestRobotSpec {
        track_m: 3.2,
        lag_s: 0.6,
        ..TestRobotSpec::warthog_on_asphalt(17)
    };
    let other = write_drive_mcap(
        &dir.path().join("ground_b.mcap"),
        "ground_b",
        "asphalt",
        spec_b,
        other_ground,
        40,
    );
    let differs = judge(
        &JudgeRequest {
            real: &other,
            model: &model,
            opts: &opts,
        },
        &|_| {},
    )
    .unwrap();
    // The robot's own runs beside it: its run on ground A, and a second run on ground B.
    let second_b = write_drive_mcap(
        &dir.path().join("ground_b_2.mcap"),
        "ground_b_2",
        "asphalt",
        TestRobotSpec {
            track_m: 3.2,
            lag_s: 0.6,
            ..TestRobotSpec::warthog_on_asphalt(29)
        },
        other_ground,
        40,
    );
    let ys = yardsticks(&YardstickRequest {
        real: &other,
        others: &[&first, &second_b],
        others_half: None,
        model: &model,
        opts: &opts,
        twin_mean_loss: differs.loss.real,
    })
    .unwrap();
    let mut with_yardsticks = differs.clone();
    with_yardsticks.yardsticks = ys.clone();
    eprintln!("{}", drive_sim::compare::judge::write::table(&with_yardsticks));
    assert!(!differs.indistinguishable, "another ground: p {}", differs.loss.p);
    // The robot's own run on ground A is far from it too, and the twin of that run is no
    // farther from it than the run itself: the yardstick test does not reject.
    let (robot_itself, same_ground) = (&ys[0], &ys[1]);
    assert!(!robot_itself.reproduces, "{robot_itself:?}");
    assert_eq!(robot_itself.twin_run_losses.len(), 19);
    assert!(robot_itself.twin_as_close, "{robot_itself:?}");
    // The robot's second run on ground B is closer to the judged run than any run of the
    // twin of ground A: the test rejects.
    assert!(
        !same_ground.twin_as_close && same_ground.p_twin_farther <= opts.alpha,
        "{same_ground:?}"
    );
}

/// Runs `drive-sim twin ARGS`, returning the exit code and stderr.
fn twin_cli(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .arg("twin")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_input_exits_with_code_2_before_any_long_work_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name);
    let s = |path: &Path| path.to_str().unwrap().to_string();
    let out = s(&p("out"));
    let warthog = p("warthog.mcap");
    write_drive_mcap(
        &warthog,
        "warthog_run",
        "asphalt",
        TestRobotSpec::warthog_on_asphalt(3),
        ground_a(),
        40,
    );
    let husky = format!(
        "{}/../shared/data/measured/husky_2023.csv",
        env!("CARGO_MANIFEST_DIR")
    );
    // Two robots.
    let (code, err) = twin_cli(&[&s(&warthog), &husky, "--out", &out]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("husky_2023") && err.contains("a twin is of one robot"),
        "{err}"
    );
    // Too short to split: 12 steps, 6 a half (a half needs 15: the calibration's split of it).
    let short = p("short.mcap");
    write_drive_mcap(
        &short,
        "short_run",
        "asphalt",
        TestRobotSpec::warthog_on_asphalt(4),
        ground_a(),
        12,
    );
    let (code, err) = twin_cli(&[&s(&short), "--out", &out]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("short.mcap") && err.contains("each half needs at least 15"),
        "{err}"
    );
    // No steady window: a measured run's transient windows only.
    let gravel = format!(
        "{}/../shared/data/measured/warthog_gravel",
        env!("CARGO_MANIFEST_DIR")
    );
    let csv = std::fs::read_to_string(format!("{gravel}.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    let window = header.split(',').position(|c| c == "window").unwrap();
    let transient: Vec<&str> = std::iter::once(header)
        .chain(lines.filter(|l| l.split(',').nth(window) == Some("0")))
        .collect();
    std::fs::write(p("transient_only.csv"), transient.join("\n") + "\n").unwrap();
    std::fs::copy(format!("{gravel}.json"), p("transient_only.json")).unwrap();
    let (code, err) = twin_cli(&[&s(&p("transient_only.csv")), "--out", &out]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("transient_only"), "{err}");
    // An unknown knob.
    let (code, err) = twin_cli(&[&s(&warthog), "--knobs", "motor_torque_speeed", "--out", &out]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("motor_torque_speeed") && err.contains("not a knob"),
        "{err}"
    );
    assert!(!p("out").exists(), "bad input wrote {out}");
}

/// The start of a twin from a run whose commands leave the configured command space U: the
/// generator's motors clip at 10 rad/s while the robot file says U is 8 rad/s per wheel (the
/// Warthog's commands reach 16). The start widens U to the commands, and reads the
/// clipping off the encoders: the saturation declared lies at the generator's limit. A run
/// whose wheels follow their commands declares none; a robot that already declares one keeps
/// it.
#[test]
fn a_start_covers_the_commands_and_declares_the_saturation_the_encoders_show() {
    use drive_sim::log::DriveLog;
    use drive_sim::twin::input::starting_models;
    let narrowed = |extra: Unmodelled| -> DriveLog {
        let (mut log, _) =
            common::generator::drive_log_with("narrow_u", TestRobotSpec::warthog_on_asphalt(5), extra, 30);
        log.meta.nominal.max_wheel_rad_s = 8.0;
        log
    };
    // The Warthog's file with U at 8 rad/s per wheel and without its declared saturation (the
    // generator's truth is its own).
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("warthog_bare.toml");
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("robots/warthog.toml")).unwrap();
    let bare: String = text[..text.find("[effects]").unwrap()]
        .lines()
        .map(|l| {
            if l.starts_with("max_wheel_rad_s") {
                "max_wheel_rad_s = 8.0"
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&file, bare).unwrap();
    let bare_file = file.to_str().unwrap();
    let clipped = narrowed(ground_a());
    let (starts, notes) = starting_models(&[&clipped], Some(bare_file), None).unwrap();
    let robot = &starts[0].robot;
    assert!(robot.powertrain.max_wheel_rad_s > 15.0, "{notes:?}");
    let at = robot.effects.get("wheel_speed_saturation_rad_s").unwrap();
    assert!((9.5..=10.6).contains(&at), "saturation {at}; {notes:?}");
    assert!(notes.iter().any(|n| n.contains("widened")) && notes.iter().any(|n| n.contains("declared")));

    let free = narrowed(Unmodelled::default());
    let (starts, notes) = starting_models(&[&free], Some(bare_file), None).unwrap();
    assert_eq!(
        starts[0].robot.effects.get("wheel_speed_saturation_rad_s"),
        Some(f64::INFINITY),
        "{notes:?}"
    );
    assert!(notes.iter().all(|n| !n.contains("declared")), "{notes:?}");

    // The Warthog's own file declares 12.7 rad/s: kept, U widened all the same.
    let (starts, notes) = starting_models(&[&clipped], None, None).unwrap();
    assert_eq!(
        starts[0].robot.effects.get("wheel_speed_saturation_rad_s"),
        Some(12.7)
    );
    assert!(notes.iter().all(|n| !n.contains("declared")), "{notes:?}");
}

/// The twin (in `dir/twin`) of an 80-step run of the generator robot on asphalt with `extra`,
/// made with `options` and the pool cut down to `knobs`.
fn twin_of_scattered(dir: &Path, extra: Unmodelled, options: TwinOptions, knobs: &[&str]) -> Twin {
    let run = dir.join("scattered.mcap");
    write_drive_mcap(
        &run,
        "scattered",
        "asphalt",
        TestRobotSpec::warthog_on_asphalt(3),
        extra,
        80,
    );
    let req = TwinRequest {
        logs: vec![run],
        out: dir.join("twin"),
        input: Default::default(),
        options,
        knobs: Some(knobs.iter().map(|k| k.to_string()).collect()),
    };
    make_twin(&req, &|e| eprintln!("{e}")).unwrap()
}

/// A second round runs from the tuned twin when the first round's check accepts its tuning:
/// over the pool's other knobs, with the refinement's rule; without an accepted tuning there is
/// none. The generator's body slips in turns and its wheels told to turn backwards go a quarter
/// slower (an asymmetric driver: the calibration by replay does not try the reverse gain, the
/// closed loop does); the pool is three knobs, so that the rounds are short. On these seeds both
/// passes accept the reverse gain and run a second round; the test asks for at least one.
///
/// The same run's steps scatter by 1.5 rad/s per wheel, and its motors do not clip (a clipped
/// wheel has no offset to show): the wheels' step offset is measured on the steps, not searched.
/// On every step a dozen pairs of neighbouring steps give a value near it (good to a few
/// tenths), declared on the twin with where it comes from; on the odd steps, where fewer than
/// five pairs may be found, a value is near it too or absent. It is never a knob of the closed
/// loop. The generator's pose changes at every sample: no update intervals are declared.
#[test]
fn a_second_round_screens_the_other_knobs_and_the_step_offset_is_measured_not_searched() {
    let dir = tempfile::tempdir().unwrap();
    let twin = twin_of_scattered(
        dir.path(),
        Unmodelled {
            step_offset_rad_s: 1.5,
            reverse_gain_change: -0.25,
            wheel_limit_rad_s: 0.0,
            ..ground_a()
        },
        TwinOptions {
            budget: 0.5,
            ..options()
        },
        &["wheel_reverse_gain", "centripetal_slip", "body_lag"],
    );
    let pool = ["body_lag", "centripetal_slip", "wheel_reverse_gain"];
    let mut second_rounds = 0;
    for pass in [&twin.report.held_out.pass, &twin.report.final_twin.pass] {
        // The scatter is measured on the steps, not searched.
        assert!(!pass
            .screening
            .knobs
            .iter()
            .any(|k| k.knob.name == "wheel_speed_scatter"));
        let scatter = pass
            .measured
            .iter()
            .find(|m| m.name == "wheel_speed_scatter_rad_s");
        eprintln!("{} steps: scatter measured {scatter:?}", pass.steps);
        if pass.steps == "all" {
            assert!(scatter.is_some(), "{:?}", pass.measured);
        }
        if let Some(m) = scatter {
            assert!((1.0..2.0).contains(&m.value), "{m:?}");
        }
        assert!(!pass.measured.iter().any(|m| m.name.starts_with("pose_update")));
        eprintln!(
            "{} steps: chose {:?}, accepted {:?}",
            pass.steps,
            pass.choice.chosen,
            pass.tuning.as_ref().map(|t| t.accepted)
        );
        // After an accepted tuning, the second round screens the others from the tuned twin,
        // whose loss it starts from; without one, there is none.
        let accepted = pass.tuning.as_ref().is_some_and(|t| t.accepted);
        assert_eq!(pass.refinement.is_some(), accepted);
        let Some(rf) = pass.refinement.as_ref() else {
            continue;
        };
        second_rounds += 1;
        let mut others: Vec<&str> = rf.screening.knobs.iter().map(|k| k.knob.name.as_str()).collect();
        others.sort_unstable();
        let not_chosen: Vec<&str> = pool
            .into_iter()
            .filter(|k| !pass.choice.chosen.iter().any(|c| c == k))
            .collect();
        assert_eq!(others, not_chosen);
        assert_eq!(rf.choice.rule, drive_sim::twin::rule::Rule::refinement());
        assert!(rf.choice.chosen.len() <= 2);
        assert_eq!(rf.tuning.is_some(), !rf.choice.chosen.is_empty());
        assert!(pass.times.iter().any(|t| t.stage == "refine"));
        // The start of the second round is the tuned twin: on the first round's search seeds
        // it scores below the calibrated model.
        let first = pass.screening.start.loss.unwrap();
        let second = rf.screening.start.loss.unwrap();
        assert!(
            second < first,
            "second round's start {second} against the calibrated {first}"
        );
    }
    assert!(second_rounds >= 1, "no pass accepted a first round's tuning");
    let robot = std::fs::read_to_string(dir.path().join("twin/twin/robot.toml")).unwrap();
    let line = robot
        .lines()
        .find(|l| l.starts_with("wheel_speed_scatter_rad_s = "))
        .unwrap_or_else(|| panic!("{robot}"));
    assert!(line.contains("[log]"), "{robot}");
}
