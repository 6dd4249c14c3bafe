//! Renders every report figure from synthetic (seeded) data, plus an HTML report embedding
//! them, to check the figures by eye.
//!
//! `cargo run --example report_demo -- [out_dir] [--measured]` (default `target/report_demo`).
//! With `--measured`, also analyses the measured datasets (`../shared/data/measured`) and
//! writes their report into `<out_dir>/measured`.
//!
//! The data are made up to look like the paper's (a Warthog on ice and asphalt); they are not
//! simulation or measurement results.

use std::path::PathBuf;

use drive_sim::kinematics::{BodyVelocity, CommandSpace, IdealDiffDrive, WheelSpeeds};
use drive_sim::report::{
    box_plots, command_space_figure, heat_maps, histograms, line_bands, risk_map, value_scatter, AxisLabel,
    BandPoint, BandSeries, BoxPanel, ColourMap, ColourScale, CommandScenario, EnergyAxis, EnergyLimit, Grid2,
    HeatPanel, HistPanel, HtmlReport, KeyFigure, LineAxes, RiskEllipse, RiskScenario, Samples, ScatterPanel,
    ValuePoint, CHI2_2DOF_95,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Warthog mass (paper), kg, and yaw inertia of a 2.13 x 1.52 m box.
const MASS_KG: f64 = 470.0;
fn izz() -> f64 {
    MASS_KG * (2.13f64.powi(2) + 1.52f64.powi(2)) / 12.0
}

struct Terrain {
    name: &'static str,
    /// Fraction of the commanded vx and wz realized by the body.
    vx_gain: f64,
    wz_gain: f64,
    /// Lateral speed scale per (vx * wz), s.
    vy_scale: f64,
    /// Left wheel reaches this fraction of its command (weak motor).
    left_gain: f64,
}

struct Step {
    cmd: WheelSpeeds,
    cmd_b: BodyVelocity,
    wheels: WheelSpeeds,
    body: BodyVelocity,
}

fn energy(v: BodyVelocity) -> f64 {
    0.5 * MASS_KG * (v.vx_m_s.powi(2) + v.vy_m_s.powi(2)) + 0.5 * izz() * v.wz_rad_s.powi(2)
}

/// ρ without the alignment penalties (demo only).
fn rho(u: BodyVelocity, x: BodyVelocity) -> f64 {
    let (ku, kx) = (energy(u), energy(x));
    4.0 / std::f64::consts::PI * (ku.atan2(kx) - std::f64::consts::FRAC_PI_4).abs()
}

fn simulate(space: &CommandSpace, t: &Terrain, n: usize, rng: &mut ChaCha8Rng) -> Vec<Step> {
    let noise = Normal::new(0.0, 1.0).expect("unit normal");
    let wm = space.max_wheel_rad_s;
    let mut out = vec![];
    while out.len() < n {
        let cmd = WheelSpeeds::new(rng.random_range(-wm..wm), rng.random_range(-wm..wm));
        if !space.contains_wheels(cmd) {
            continue;
        }
        let cmd_b = space.idd.body_from_wheels(cmd);
        let wheels = WheelSpeeds::new(
            cmd.left_rad_s * t.left_gain + 0.2 * noise.sample(rng),
            cmd.right_rad_s + 0.2 * noise.sample(rng),
        );
        let body = BodyVelocity::new(
            cmd_b.vx_m_s * t.vx_gain + 0.05 * noise.sample(rng),
            t.vy_scale * cmd_b.vx_m_s * cmd_b.wz_rad_s * (1.0 + 0.3 * noise.sample(rng)),
            cmd_b.wz_rad_s * t.wz_gain + 0.05 * noise.sample(rng),
        );
        out.push(Step {
            cmd,
            cmd_b,
            wheels,
            body,
        });
    }
    out
}

/// Gaussian kernel smoother of `f(step)` onto a grid over U (diagonal Σ = sigma2 I).
fn smooth(space: &CommandSpace, steps: &[Step], sigma2: f64, f: impl Fn(&Step) -> f64) -> Grid2 {
    let vx: Vec<f64> = (-50..=50).map(|i| f64::from(i) * 0.1).collect();
    let wz: Vec<f64> = (-40..=40).map(|i| f64::from(i) * 0.1).collect();
    Grid2::from_fn(vx, wz, |x, w| {
        if !space.contains_body(BodyVelocity::new(x, 0.0, w)) {
            return None;
        }
        let (mut num, mut den) = (0.0, 0.0);
        for s in steps {
            let d2 = (s.cmd_b.vx_m_s - x).powi(2) + (s.cmd_b.wz_rad_s - w).powi(2);
            let k = (-0.5 * d2 / sigma2).exp();
            num += k * f(s);
            den += k;
        }
        (den > 1e-12).then(|| num / den)
    })
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn covariance(a: &[f64], b: &[f64]) -> [[f64; 2]; 2] {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let c = |x: &[f64], mx: f64, y: &[f64], my: f64| {
        x.iter().zip(y).map(|(p, q)| (p - mx) * (q - my)).sum::<f64>() / (n - 1.0)
    };
    let ab = c(a, ma, b, mb);
    [[c(a, ma, a, ma), ab], [ab, c(b, mb, b, mb)]]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let measured = args.iter().any(|a| a == "--measured");
    let out: PathBuf = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .map_or_else(|| PathBuf::from("target/report_demo"), PathBuf::from);
    if measured {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/measured");
        let params = drive_sim::analysis::AnalysisParams::default();
        let mut logs = vec![];
        for f in [
            "warthog_ice.csv",
            "warthog_asphalt.csv",
            "warthog_gravel.csv",
            "husky_2023.csv",
        ] {
            let log = drive_sim::log::csv::read_measured_csv(dir.join(f))?;
            let analysis = drive_sim::analysis::analyze(&log, &params)?;
            logs.push((log, analysis));
        }
        let items: Vec<_> = logs.iter().map(|(l, a)| (l, a)).collect();
        let html =
            drive_sim::report::analysis_report::write_analysis_report(&items, &out.join("measured"))?.html;
        println!("wrote {}", html.display());
    }
    let space = CommandSpace {
        idd: IdealDiffDrive {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
        },
        max_wheel_rad_s: 16.6667,
        max_lin_m_s: 5.0,
        max_ang_rad_s: 4.0,
        turn_scale: 1.0,
    };
    let terrains = [
        Terrain {
            name: "ice",
            vx_gain: 0.5,
            wz_gain: 0.35,
            vy_scale: 0.12,
            left_gain: 1.0,
        },
        Terrain {
            name: "asphalt",
            vx_gain: 0.95,
            wz_gain: 0.6,
            vy_scale: 0.04,
            left_gain: 0.88,
        },
        Terrain {
            name: "gravel",
            vx_gain: 0.9,
            wz_gain: 0.55,
            vy_scale: 0.05,
            left_gain: 1.0,
        },
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let runs: Vec<Vec<Step>> = terrains
        .iter()
        .map(|t| simulate(&space, t, 250, &mut rng))
        .collect();
    let mut report = HtmlReport::new("drive-sim report demo (synthetic data)");
    report
        .paragraph("All data on this page are synthetic and seeded; they only exercise the figure builders.");

    // 1. Command space.
    let scen: Vec<CommandScenario> = terrains
        .iter()
        .zip(&runs)
        .take(2)
        .map(|(t, r)| CommandScenario {
            label: t.name.to_string(),
            commands: r.iter().map(|s| s.cmd).collect(),
            steady_wheels: r.iter().map(|s| s.wheels).collect(),
            steady_body: r.iter().map(|s| s.body).collect(),
        })
        .collect();
    let f = command_space_figure(&out, "command_space", "Warthog: U, S and T", &space, &scen)?;
    report
        .section("Command space")
        .figure("U (black), sampled commands S (orange) and steady-state T.", &f)?;

    // 2. Slip and ρ box plots.
    let group = |f: &dyn Fn(&Step) -> f64| -> Vec<Samples> {
        let mut g: Vec<Samples> = terrains
            .iter()
            .zip(&runs)
            .map(|(t, r)| Samples::new(t.name, r.iter().map(f).collect()))
            .collect();
        g.push(Samples::new("all", runs.iter().flatten().map(f).collect()));
        g
    };
    let panel = |title: &str, q: &str, unit: &str, f: &dyn Fn(&Step) -> f64| BoxPanel {
        title: title.into(),
        value: AxisLabel::new(q, unit),
        groups: group(f),
    };
    let slips = [
        panel("longitudinal", "slip g_vx", "m/s", &|s| {
            s.cmd_b.vx_m_s - s.body.vx_m_s
        }),
        panel("lateral", "slip g_vy", "m/s", &|s| -s.body.vy_m_s),
        panel("angular", "slip g_wz", "rad/s", &|s| {
            s.cmd_b.wz_rad_s - s.body.wz_rad_s
        }),
        panel("left wheel", "slip g_l", "rad/s", &|s| {
            s.cmd.left_rad_s - s.wheels.left_rad_s
        }),
        panel("right wheel", "slip g_r", "rad/s", &|s| {
            s.cmd.right_rad_s - s.wheels.right_rad_s
        }),
    ];
    let f = box_plots(&out, "slip_boxplots", "Steady-state slip per terrain", &slips)?;
    report
        .section("Slip")
        .figure("Boxes: quartiles; line: median; whiskers: 2.5–97.5 %.", &f)?;
    let rho_panel = [panel("ρ", "unpredictability ρ", "", &|s| rho(s.cmd_b, s.body))];
    let f = box_plots(&out, "rho_boxplot", "Unpredictability per terrain", &rho_panel)?;
    report.section("Unpredictability").figure("ρ per terrain.", &f)?;

    // 3. Transfer functions.
    let poly = space.polygon_body();
    for (stem, q, spacing, f) in [
        (
            "tf_longitudinal",
            "longitudinal slip",
            0.2,
            &(|s: &Step| s.cmd_b.vx_m_s - s.body.vx_m_s) as &dyn Fn(&Step) -> f64,
        ),
        ("tf_lateral", "lateral slip", 0.1, &|s: &Step| -s.body.vy_m_s),
    ] {
        let panels: Vec<HeatPanel> = terrains
            .iter()
            .zip(&runs)
            .take(2)
            .map(|(t, r)| HeatPanel {
                title: t.name.to_string(),
                grid: smooth(&space, r, 0.64, f),
                command_space: poly.clone(),
            })
            .collect();
        let scale = ColourScale {
            value: AxisLabel::new(q, "m/s"),
            map: ColourMap::Diverging,
            range: None,
        };
        let fig = heat_maps(
            &out,
            stem,
            &format!("Transfer function: {q}"),
            &panels,
            &scale,
            Some(spacing),
        )?;
        report.figure(format!("{q}, contours every {spacing} m/s."), &fig)?;
    }

    // 4. ρ over the command space.
    let rho_scale = ColourScale {
        value: AxisLabel::new("unpredictability ρ", ""),
        map: ColourMap::Viridis,
        range: Some((0.0, 1.0)),
    };
    let panels: Vec<ScatterPanel> = terrains
        .iter()
        .zip(&runs)
        .take(2)
        .map(|(t, r)| ScatterPanel {
            title: t.name.to_string(),
            points: r
                .iter()
                .map(|s| ValuePoint {
                    vx_m_s: s.cmd_b.vx_m_s,
                    wz_rad_s: s.cmd_b.wz_rad_s,
                    value: rho(s.cmd_b, s.body),
                })
                .collect(),
            command_space: poly.clone(),
        })
        .collect();
    let f = value_scatter(
        &out,
        "rho_scatter",
        "ρ at the sampled commands",
        &panels,
        &rho_scale,
    )?;
    report.figure("ρ per step at its command.", &f)?;
    let panels: Vec<HeatPanel> = terrains
        .iter()
        .zip(&runs)
        .take(2)
        .map(|(t, r)| HeatPanel {
            title: t.name.to_string(),
            grid: smooth(&space, r, 0.64, |s| rho(s.cmd_b, s.body)),
            command_space: poly.clone(),
        })
        .collect();
    let f = heat_maps(
        &out,
        "rho_map",
        "ρ over the command space",
        &panels,
        &rho_scale,
        None,
    )?;
    report.figure("ρ smoothed onto a 0.1 grid.", &f)?;

    // 5. Risk map.
    let mut scenarios = vec![];
    for (t, r) in terrains.iter().zip(&runs) {
        for (motion, dashed) in [("motion 1", false), ("motion 2", true)] {
            // Motion 1: forward-dominant steps; motion 2: rotation-dominant.
            let sel: Vec<&Step> = r
                .iter()
                .filter(|s| (s.cmd_b.vx_m_s.abs() / 5.0 > s.cmd_b.wz_rad_s.abs() / 4.0) != dashed)
                .collect();
            let rh: Vec<f64> = sel.iter().map(|s| rho(s.cmd_b, s.body)).collect();
            let e: Vec<f64> = sel.iter().map(|s| energy(s.body)).collect();
            scenarios.push(RiskScenario {
                label: format!("Warthog {}, {motion}", t.name),
                colour_key: t.name.to_string(),
                median_rho: median(&rh),
                median_energy_j: median(&e),
                ellipse: Some(RiskEllipse {
                    centre: (mean(&rh), mean(&e)),
                    covariance: covariance(&rh, &e),
                }),
                dashed,
            });
        }
    }
    let e_max = poly
        .iter()
        .map(|&(vx, wz)| energy(BodyVelocity::new(vx, 0.0, wz)))
        .fold(0.0, f64::max);
    let limits = [EnergyLimit {
        label: "Warthog max on flat ground".into(),
        energy_j: e_max,
    }];
    let f = risk_map(
        &out,
        "risk_map",
        "Risk: likelihood vs severity",
        &scenarios,
        &limits,
        CHI2_2DOF_95,
        EnergyAxis::Linear,
    )?;
    report
        .section("Risk")
        .figure("Median and 95 % ellipse per scenario.", &f)?;
    // Both robots on a log energy axis: covariance of (ρ, log10 E). The "Husky" here is the
    // Warthog data scaled by mass (75/470) and speed squared ((1/5)^2); synthetic.
    let husky_scale = 75.0 / 470.0 / 25.0;
    let mut log_scen = vec![];
    for (robot, k) in [("Warthog", 1.0), ("Husky", husky_scale)] {
        for (t, r) in terrains.iter().zip(&runs).take(2) {
            let rh: Vec<f64> = r.iter().map(|s| rho(s.cmd_b, s.body)).collect();
            let le: Vec<f64> = r.iter().map(|s| (k * energy(s.body)).max(1e-3).log10()).collect();
            log_scen.push(RiskScenario {
                label: format!("{robot} {}", t.name),
                colour_key: t.name.to_string(),
                median_rho: median(&rh),
                median_energy_j: 10f64.powf(median(&le)),
                ellipse: Some(RiskEllipse {
                    centre: (mean(&rh), mean(&le)),
                    covariance: covariance(&rh, &le),
                }),
                dashed: robot == "Husky",
            });
        }
    }
    let log_limits = [
        EnergyLimit {
            label: "Warthog max".into(),
            energy_j: e_max,
        },
        EnergyLimit {
            label: "Husky max".into(),
            energy_j: e_max * husky_scale,
        },
    ];
    let f = risk_map(
        &out,
        "risk_map_log",
        "Risk: two robots, log severity",
        &log_scen,
        &log_limits,
        CHI2_2DOF_95,
        EnergyAxis::Log10,
    )?;
    report.figure(
        "Log energy axis; ellipses from the covariance of (ρ, log10 E).",
        &f,
    )?;

    // 6. Accelerations of the first 2 s.
    let normal = |sd: f64, n: usize, rng: &mut ChaCha8Rng| -> Vec<f64> {
        let d = Normal::new(0.0, sd).expect("positive sd");
        (0..n).map(|_| d.sample(rng)).collect()
    };
    let mut hp = vec![];
    for (title, unit, limit, sds) in [
        ("longitudinal", "m/s²", Some(4.0), (0.8, 1.8)),
        ("lateral", "m/s²", None, (0.5, 0.9)),
        ("angular", "rad/s²", Some(6.0), (1.2, 2.6)),
    ] {
        hp.push(HistPanel {
            title: title.into(),
            value: AxisLabel::new(format!("{title} acceleration"), unit),
            limit,
            series: vec![
                Samples::new("ice", normal(sds.0, 4000, &mut rng)),
                Samples::new("asphalt", normal(sds.1, 4000, &mut rng)),
            ],
        });
    }
    let f = histograms(
        &out,
        "accelerations",
        "Accelerations during the first 2 s",
        &hp,
        41,
    )?;
    report.section("Accelerations").figure("Red: limits.", &f)?;

    // 7. Error vs number of steps.
    let series: Vec<BandSeries> = [("uniform sampler", 1.0), ("stratified sampler", 0.7)]
        .iter()
        .map(|&(label, k)| BandSeries {
            label: label.into(),
            points: [10, 20, 40, 80, 150, 250]
                .iter()
                .map(|&n| {
                    let m = k / f64::from(n).sqrt();
                    BandPoint {
                        x: f64::from(n),
                        mean: m,
                        low: 0.7 * m,
                        high: 1.3 * m,
                    }
                })
                .collect(),
        })
        .collect();
    let f = line_bands(
        &out,
        "error_vs_steps",
        "Calibration error vs number of steps",
        &LineAxes {
            x: AxisLabel::new("number of DRIVE steps", ""),
            y: AxisLabel::new("wheel radius error", "m"),
            log_x: true,
            log_y: true,
        },
        &series,
    )?;
    report
        .section("Calibration")
        .figure("Mean and 95 % band over seeds.", &f)?
        .table(
            "Key figures",
            &[
                KeyFigure::new("maximum kinetic energy (IDD over U)", format!("{e_max:.0}"), "J"),
                KeyFigure::new("steps per terrain", 250, ""),
            ],
        );
    let html = report.write(&out)?;
    println!("wrote {}", html.display());
    Ok(())
}
