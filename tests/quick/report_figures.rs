//! Figure builders on synthetic data: valid SVG with the expected labels, a PNG of the same
//! size, NaN accounting, and errors (not panics) for impossible requests.

use std::path::Path;

use drive_sim::kinematics::{BodyVelocity, CommandSpace, IdealDiffDrive, WheelSpeeds};
use drive_sim::report::Error;
use drive_sim::report::{
    box_plots, command_space_figure, contour_segments, heat_maps, histograms, line_bands, risk_map,
    scenario_colour, value_scatter, AxisLabel, BandPoint, BandSeries, BoxPanel, ColourMap, ColourScale,
    CommandScenario, EnergyAxis, EnergyLimit, FigureFiles, Grid2, HeatPanel, HistPanel, HtmlReport,
    KeyFigure, LineAxes, RiskEllipse, RiskScenario, Samples, ScatterPanel, ValuePoint, CHI2_2DOF_95,
};

fn husky() -> CommandSpace {
    CommandSpace {
        idd: IdealDiffDrive {
            wheel_radius_m: 0.165,
            baseline_m: 0.555,
        },
        max_wheel_rad_s: 6.06,
        max_lin_m_s: 1.0,
        max_ang_rad_s: 2.0,
        turn_scale: 1.0,
    }
}

/// `width="W" height="H"` of the root `<svg>` element.
fn svg_size(svg: &str) -> (u32, u32) {
    let head = &svg[..svg.find('>').expect("svg start tag closes")];
    let attr = |name: &str| -> u32 {
        let key = format!("{name}=\"");
        let i = head.find(&key).expect("attribute present") + key.len();
        let j = head[i..].find('"').expect("attribute closes") + i;
        head[i..j].parse().expect("integer size")
    };
    (attr("width"), attr("height"))
}

/// Checks both files and returns the SVG text.
fn check_files(f: &FigureFiles, labels: &[&str]) -> String {
    let svg = std::fs::read_to_string(&f.svg).expect("svg written");
    assert!(svg.starts_with("<svg"), "SVG starts with <svg");
    assert!(svg.trim_end().ends_with("</svg>"), "SVG is closed");
    assert_eq!(
        svg.matches("<text").count(),
        svg.matches("</text>").count(),
        "balanced text elements"
    );
    for l in labels {
        assert!(svg.contains(l), "SVG mentions `{l}`");
    }
    let (w, h) = svg_size(&svg);
    let decoder = png::Decoder::new(std::fs::File::open(&f.png).expect("png written"));
    let reader = decoder.read_info().expect("valid PNG");
    assert_eq!(
        (reader.info().width, reader.info().height),
        (w, h),
        "PNG size = SVG size"
    );
    assert!(w >= 400 && h >= 300, "a readable size, got {w}x{h}");
    svg
}

fn steady(n: usize, gain: f64) -> CommandScenario {
    let s = husky();
    let mut c = CommandScenario {
        label: "grass".into(),
        ..Default::default()
    };
    for k in 0..n {
        let a = k as f64 * 0.7;
        let cmd = WheelSpeeds::new(5.0 * a.cos(), 5.0 * (1.3 * a).sin());
        if !s.contains_wheels(cmd) {
            continue;
        }
        let b = s.idd.body_from_wheels(cmd);
        c.commands.push(cmd);
        c.steady_wheels
            .push(WheelSpeeds::new(cmd.left_rad_s * gain, cmd.right_rad_s));
        c.steady_body.push(BodyVelocity::new(
            b.vx_m_s * gain,
            0.02 * a.sin(),
            b.wz_rad_s * gain,
        ));
    }
    c
}

#[test]
fn command_space_figure_files_and_nan_count() {
    let dir = tempfile::tempdir().unwrap();
    let mut grass = steady(60, 0.8);
    let mut ice = steady(40, 0.4);
    ice.label = "ice".into();
    grass.steady_body.push(BodyVelocity::new(f64::NAN, 0.0, 0.0));
    grass.commands.push(WheelSpeeds::new(f64::INFINITY, 0.0));
    let f = command_space_figure(dir.path(), "cs", "Husky U/S/T", &husky(), &[grass, ice]).unwrap();
    let svg = check_files(
        &f,
        &[
            "Husky U/S/T",
            "S (sampled commands)",
            "T (steady state), ice",
            "wheel frame W",
            "lateral speed vy [m/s]",
        ],
    );
    assert_eq!(f.skipped_non_finite, 2);
    // Three panels per scenario, two rows: the PNG is three panels wide.
    assert_eq!(svg_size(&svg).0, 3 * 470);
    assert!(matches!(
        command_space_figure(dir.path(), "cs2", "t", &husky(), &[]),
        Err(Error::NothingToDraw { what: "scenario", .. })
    ));
    // A scenario without data draws an empty row, no error.
    let empty = CommandScenario {
        label: "mud".into(),
        ..Default::default()
    };
    let f = command_space_figure(dir.path(), "cs3", "t", &husky(), &[empty]).unwrap();
    check_files(&f, &["no data"]);
}

#[test]
fn box_plots_labels_nan_empty_and_constant() {
    let dir = tempfile::tempdir().unwrap();
    let panels = [
        BoxPanel {
            title: "longitudinal".into(),
            value: AxisLabel::new("slip", "m/s"),
            groups: vec![
                Samples::new("ice", (0..100).map(|i| f64::from(i) / 50.0).collect()),
                Samples::new("asphalt", vec![0.1, f64::NAN, 0.2, 0.3]),
                Samples::new("all", vec![0.5; 10]), // all equal
                Samples::new("sand", vec![]),       // empty group
            ],
        },
        BoxPanel {
            title: "rho".into(),
            value: AxisLabel::new("ρ", ""),
            groups: vec![Samples::new("ice", vec![0.4])], // single point
        },
    ];
    let f = box_plots(dir.path(), "box", "Slip", &panels).unwrap();
    check_files(
        &f,
        &[
            "ice",
            "asphalt",
            "all",
            "sand",
            "n=100",
            "n=3",
            "no data",
            "slip [m/s]",
        ],
    );
    assert_eq!(f.skipped_non_finite, 1);
    assert!(box_plots(dir.path(), "box2", "Slip", &[]).is_err());
    assert!(box_plots(dir.path(), "../escape", "Slip", &panels).is_err());
}

#[test]
fn heat_maps_with_contours_mask_and_colour_bar() {
    let dir = tempfile::tempdir().unwrap();
    let s = husky();
    let axis = |lo: f64, hi: f64, n: usize| -> Vec<f64> {
        (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect()
    };
    let grid = Grid2::from_fn(axis(-1.0, 1.0, 21), axis(-2.0, 2.0, 41), |vx, wz| {
        s.contains_body(BodyVelocity::new(vx, 0.0, wz))
            .then_some(0.5 * vx + 0.1 * wz)
    });
    let mut with_nan = grid.clone();
    with_nan.values[0] = Some(f64::NAN);
    with_nan.values[220] = Some(f64::NAN);
    let panels = [
        HeatPanel {
            title: "ice".into(),
            grid: grid.clone(),
            command_space: s.polygon_body(),
        },
        HeatPanel {
            title: "asphalt".into(),
            grid: with_nan,
            command_space: s.polygon_body(),
        },
    ];
    let scale = ColourScale {
        value: AxisLabel::new("longitudinal slip", "m/s"),
        map: ColourMap::Diverging,
        range: None,
    };
    let f = heat_maps(dir.path(), "tf", "Transfer function", &panels, &scale, Some(0.2)).unwrap();
    check_files(
        &f,
        &[
            "longitudinal slip [m/s]",
            "contours every 0.2 m/s",
            "ice",
            "asphalt",
        ],
    );
    assert_eq!(f.skipped_non_finite, 2);
    // The contour at 0.2 of z = 0.5 vx + 0.1 wz lies on that line, inside U only.
    let segs = contour_segments(&grid, 0.2).unwrap();
    assert!(!segs.is_empty());
    for (a, b) in segs {
        for (vx, wz) in [a, b] {
            assert!((0.5 * vx + 0.1 * wz - 0.2).abs() < 1e-9);
        }
    }
    // Impossible requests.
    assert!(heat_maps(dir.path(), "tf2", "t", &[], &scale, None).is_err());
    assert!(heat_maps(dir.path(), "tf3", "t", &panels, &scale, Some(-0.1)).is_err());
    let bad_range = ColourScale {
        range: Some((1.0, 1.0)),
        ..scale.clone()
    };
    assert!(heat_maps(dir.path(), "tf4", "t", &panels, &bad_range, None).is_err());
    let mut bad = panels[0].clone();
    bad.grid.values.pop();
    let e = heat_maps(dir.path(), "tf5", "t", &[bad], &scale, None).unwrap_err();
    assert!(e.to_string().contains("panel `ice`"), "{e}");
    // A fully masked grid and a single-point grid still draw.
    let masked = HeatPanel {
        title: "mud".into(),
        grid: Grid2::from_fn(vec![0.0, 1.0], vec![0.0, 1.0], |_, _| None),
        command_space: vec![],
    };
    let one = HeatPanel {
        title: "one".into(),
        grid: Grid2::from_fn(vec![0.5], vec![0.5], |_, _| Some(1.0)),
        command_space: vec![],
    };
    let f = heat_maps(dir.path(), "tf6", "t", &[masked, one], &scale, Some(0.1)).unwrap();
    check_files(&f, &["no data inside U"]);
}

#[test]
fn value_scatter_rho() {
    let dir = tempfile::tempdir().unwrap();
    let pts: Vec<ValuePoint> = (0..50)
        .map(|k| {
            let a = f64::from(k) * 0.3;
            ValuePoint {
                vx_m_s: 0.8 * a.cos(),
                wz_rad_s: 1.5 * a.sin(),
                value: (f64::from(k) / 50.0),
            }
        })
        .chain(std::iter::once(ValuePoint {
            vx_m_s: 0.0,
            wz_rad_s: 0.0,
            value: f64::NAN,
        }))
        .collect();
    let panels = [ScatterPanel {
        title: "grass".into(),
        points: pts,
        command_space: husky().polygon_body(),
    }];
    let scale = ColourScale {
        value: AxisLabel::new("unpredictability ρ", ""),
        map: ColourMap::Viridis,
        range: Some((0.0, 1.0)),
    };
    let f = value_scatter(dir.path(), "rho", "ρ over U", &panels, &scale).unwrap();
    check_files(
        &f,
        &["unpredictability ρ", "grass", "commanded yaw rate ωz [rad/s]"],
    );
    assert_eq!(f.skipped_non_finite, 1);
    assert!(value_scatter(dir.path(), "rho2", "t", &[], &scale).is_err());
}

#[test]
fn risk_map_ellipses_and_limits() {
    let dir = tempfile::tempdir().unwrap();
    let sc = |label: &str, key: &str, rho: f64, e: f64, dashed: bool| RiskScenario {
        label: label.into(),
        colour_key: key.into(),
        median_rho: rho,
        median_energy_j: e,
        ellipse: Some(RiskEllipse {
            centre: (rho, e),
            covariance: [[0.004, 0.5], [0.5, 400.0]],
        }),
        dashed,
    };
    let scenarios = [
        sc("Husky ice, motion 1", "ice", 0.6, 30.0, false),
        sc("Husky ice, motion 2", "ice", 0.7, 10.0, true),
        sc("Husky asphalt, motion 1", "asphalt", 0.2, 35.0, false),
        sc("broken", "mud", f64::NAN, 1.0, false),
    ];
    let limits = [EnergyLimit {
        label: "Husky max".into(),
        energy_j: 37.5,
    }];
    let f = risk_map(
        dir.path(),
        "risk",
        "Risk",
        &scenarios,
        &limits,
        CHI2_2DOF_95,
        EnergyAxis::Linear,
    )
    .unwrap();
    let svg = check_files(
        &f,
        &["Husky ice, motion 2", "Husky max = 38 J", "kinetic energy [J]"],
    );
    assert_eq!(f.skipped_non_finite, 1);
    // Colours come from the colour key: ice blue and asphalt grey both appear.
    for c in [scenario_colour("ice"), scenario_colour("asphalt")] {
        let hex = format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
        assert!(svg.contains(&hex), "colour {hex} used");
    }
    let mut bad = scenarios[0].clone();
    bad.ellipse = Some(RiskEllipse {
        centre: (0.5, 1.0),
        covariance: [[1.0, 2.0], [2.0, 1.0]],
    });
    let e = risk_map(
        dir.path(),
        "risk2",
        "Risk",
        &[bad],
        &limits,
        CHI2_2DOF_95,
        EnergyAxis::Linear,
    )
    .unwrap_err();
    assert!(e.to_string().contains("positive semi-definite"), "{e}");
    assert!(risk_map(
        dir.path(),
        "risk3",
        "Risk",
        &[],
        &[],
        CHI2_2DOF_95,
        EnergyAxis::Linear
    )
    .is_err());
    assert!(risk_map(
        dir.path(),
        "risk4",
        "Risk",
        &scenarios[..1],
        &[],
        0.0,
        EnergyAxis::Linear
    )
    .is_err());
    // Log axis: covariance of (ρ, log10 E); a zero-energy median cannot be placed.
    let mut log_sc = vec![
        sc("Warthog ice", "ice", 0.6, 3000.0, false),
        sc("Husky ice", "ice", 0.5, 20.0, true),
    ];
    for s in &mut log_sc {
        s.ellipse = Some(RiskEllipse {
            centre: (s.median_rho, s.median_energy_j.log10()),
            covariance: [[0.004, 0.001], [0.001, 0.04]],
        });
    }
    // A scenario with too few steps for an ellipse: its median alone.
    let mut lone = sc("Husky sand", "sand", 0.3, 5.0, false);
    lone.ellipse = None;
    log_sc.push(lone);
    log_sc.push(sc("standing", "mud", 0.9, 0.0, false));
    let limits = [
        EnergyLimit {
            label: "Warthog max".into(),
            energy_j: 5875.0,
        },
        EnergyLimit {
            label: "Husky max".into(),
            energy_j: 37.5,
        },
    ];
    let f = risk_map(
        dir.path(),
        "risk5",
        "Risk",
        &log_sc,
        &limits,
        CHI2_2DOF_95,
        EnergyAxis::Log10,
    )
    .unwrap();
    check_files(&f, &["Warthog max = 5875 J", "Husky max = 38 J", "Husky ice"]);
    assert_eq!(f.skipped_non_finite, 1);
}

#[test]
fn acceleration_histograms_with_limits() {
    let dir = tempfile::tempdir().unwrap();
    let vals = |k: f64| -> Vec<f64> { (0..400).map(|i| k * ((f64::from(i) * 0.37).sin())).collect() };
    let panels = [
        HistPanel {
            title: "longitudinal".into(),
            value: AxisLabel::new("acceleration", "m/s²"),
            limit: Some(4.0),
            series: vec![Samples::new("ice", vals(1.0)), Samples::new("asphalt", vals(3.0))],
        },
        HistPanel {
            title: "lateral".into(),
            value: AxisLabel::new("acceleration", "m/s²"),
            limit: None,
            series: vec![
                Samples::new("ice", vec![1.0; 5]),
                Samples::new("asphalt", vec![f64::NAN]),
            ],
        },
    ];
    let f = histograms(dir.path(), "acc", "Accelerations", &panels, 30).unwrap();
    check_files(&f, &["acceleration [m/s²]", "limit", "ice", "asphalt"]);
    assert_eq!(f.skipped_non_finite, 1);
    assert!(histograms(dir.path(), "acc2", "t", &panels, 0).is_err());
    assert!(histograms(dir.path(), "acc3", "t", &[], 10).is_err());
}

#[test]
fn line_bands_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let series = [
        BandSeries {
            label: "before calibration".into(),
            points: (1..=8)
                .map(|k| {
                    let x = f64::from(k) * 20.0;
                    BandPoint {
                        x,
                        mean: 1.0 / x.sqrt(),
                        low: 0.8 / x.sqrt(),
                        high: 1.2 / x.sqrt(),
                    }
                })
                .chain(std::iter::once(BandPoint {
                    x: f64::NAN,
                    ..Default::default()
                }))
                .collect(),
        },
        BandSeries {
            label: "after calibration".into(),
            points: vec![BandPoint {
                x: 50.0,
                mean: 0.05,
                low: 0.04,
                high: 0.06,
            }],
        },
    ];
    let f = line_bands(
        dir.path(),
        "err",
        "Residual",
        &LineAxes {
            x: AxisLabel::new("number of steps", ""),
            y: AxisLabel::new("residual", "m/s"),
            ..Default::default()
        },
        &series,
    )
    .unwrap();
    check_files(&f, &["before calibration", "after calibration", "residual [m/s]"]);
    assert_eq!(f.skipped_non_finite, 1);
    let inverted = [BandSeries {
        label: "x".into(),
        points: vec![BandPoint {
            x: 1.0,
            mean: 0.0,
            low: 1.0,
            high: -1.0,
        }],
    }];
    let x = LineAxes {
        x: AxisLabel::new("x", ""),
        y: AxisLabel::new("y", ""),
        ..Default::default()
    };
    assert!(line_bands(dir.path(), "err2", "t", &x, &inverted).is_err());
    assert!(line_bands(dir.path(), "err3", "t", &x, &[]).is_err());
    // Log-log: the point at x = 0 and the band reaching 0 cannot be placed.
    let log = LineAxes {
        log_x: true,
        log_y: true,
        ..x.clone()
    };
    let mut s = series[0].clone();
    s.points.push(BandPoint {
        x: 0.0,
        mean: 1.0,
        low: 0.5,
        high: 2.0,
    });
    s.points.push(BandPoint {
        x: 5.0,
        mean: 1.0,
        low: 0.0,
        high: 2.0,
    });
    let f = line_bands(dir.path(), "err4", "t", &log, &[s]).unwrap();
    check_files(&f, &["before calibration"]);
    assert_eq!(f.skipped_non_finite, 3);
}

#[test]
fn html_report_is_self_contained() {
    let dir = tempfile::tempdir().unwrap();
    let panels = [BoxPanel {
        title: "ρ".into(),
        value: AxisLabel::new("ρ", ""),
        groups: vec![Samples::new("ice", vec![0.1, 0.5, f64::NAN])],
    }];
    let f = box_plots(dir.path(), "rho", "ρ <per> terrain", &panels).unwrap();
    let mut r = HtmlReport::new("Run <1> & co");
    r.section("ρ").paragraph("a < b").table(
        "Key figures",
        &[KeyFigure::new("median ρ", format!("{:.2}", 0.3), "")],
    );
    r.figure("Box plot", &f).unwrap();
    let path = r.write(&dir.path().join("out")).unwrap();
    assert_eq!(path.file_name().unwrap(), "report.html");
    let html = std::fs::read_to_string(&path).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(html.contains("<title>Run &lt;1&gt; &amp; co</title>"));
    assert!(html.contains("<p>a &lt; b</p>"));
    assert!(html.contains("<td class=\"v\">0.30</td>"));
    // The figure is inline: one <svg> element, and no external reference.
    assert_eq!(html.matches("<svg").count(), 1);
    assert!(
        html.contains("ρ &lt;per&gt; terrain"),
        "SVG text is escaped by the backend"
    );
    assert!(!html.contains("<img") && !html.contains("src=\"") && !html.contains("href=\""));
    assert!(html.contains("(1 non-finite values left out.)"));
    // A missing SVG is an I/O error naming the file.
    let missing = FigureFiles {
        svg: Path::new("/nonexistent/x.svg").into(),
        png: Path::new("/nonexistent/x.png").into(),
        skipped_non_finite: 0,
    };
    let e = r.figure("x", &missing).expect_err("missing file is an error");
    assert!(e.to_string().contains("/nonexistent/x.svg"), "{e}");
}

#[test]
fn extreme_and_degenerate_values_do_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    let wild = vec![1e300, -1e300, 0.0, f64::MAX, f64::MIN_POSITIVE];
    let panels = [BoxPanel {
        title: "wild".into(),
        value: AxisLabel::new("x", ""),
        groups: vec![Samples::new("a", wild.clone()), Samples::new("b", vec![0.0; 3])],
    }];
    box_plots(dir.path(), "b", "t", &panels).unwrap();
    let hp = [HistPanel {
        title: "wild".into(),
        value: AxisLabel::new("x", ""),
        limit: Some(f64::INFINITY),
        series: vec![Samples::new("a", wild.clone())],
    }];
    histograms(dir.path(), "h", "t", &hp, 10).unwrap();
    let series = [BandSeries {
        label: "a".into(),
        points: wild
            .iter()
            .map(|&v| BandPoint {
                x: v,
                mean: v,
                low: v,
                high: v,
            })
            .collect(),
    }];
    let axes = LineAxes {
        log_y: true,
        ..Default::default()
    };
    line_bands(dir.path(), "l", "t", &axes, &series).unwrap();
    let f = line_bands(dir.path(), "l2", "t", &LineAxes::default(), &series).unwrap();
    check_files(&f, &["a"]);
    let huge = CommandScenario {
        label: "huge".into(),
        commands: vec![WheelSpeeds::new(1e300, -f64::MAX)],
        steady_wheels: vec![WheelSpeeds::new(f64::MAX, 0.0)],
        steady_body: vec![BodyVelocity::new(f64::MAX, -f64::MAX, 1e300)],
    };
    command_space_figure(dir.path(), "c", "t", &husky(), &[huge]).unwrap();
    let risky = RiskScenario {
        label: "r".into(),
        colour_key: "r".into(),
        median_rho: 0.5,
        median_energy_j: 1e300,
        ellipse: Some(RiskEllipse {
            centre: (0.5, 1e300),
            covariance: [[1.0, 0.0], [0.0, 1e300]],
        }),
        dashed: false,
    };
    risk_map(
        dir.path(),
        "r",
        "t",
        &[risky],
        &[],
        CHI2_2DOF_95,
        EnergyAxis::Linear,
    )
    .unwrap();
}

#[test]
fn histogram_axis_ignores_rare_outliers_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    // 1000 samples in [-1, 1] and 2 outliers at ±100: the axis stays near ±1 and the two
    // outliers are reported.
    let mut v: Vec<f64> = (0..1000).map(|i| -1.0 + 2.0 * f64::from(i) / 999.0).collect();
    v.extend([100.0, -100.0]);
    let panels = [HistPanel {
        title: "ax".into(),
        value: AxisLabel::new("acceleration", "m/s²"),
        limit: Some(2.0),
        series: vec![Samples::new("ice", v)],
    }];
    let f = histograms(dir.path(), "h", "t", &panels, 20).unwrap();
    let svg = check_files(&f, &["2 samples beyond the axis"]);
    // No tick label as far out as ±100 (or ±50).
    assert!(!svg.contains(">\n100\n<") && !svg.contains(">\n50\n<"));
}
