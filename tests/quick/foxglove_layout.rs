//! The Foxglove layout shipped in `foxglove/` shows what drive-sim logs: every topic its panels
//! read is a topic the MCAP writer writes, and every topic the writer writes is on some panel.

use drive_sim::log::mcap::{
    TOPIC_CMD_VEL, TOPIC_ICP_ODOM, TOPIC_IMU, TOPIC_JOINT_STATES, TOPIC_MARKER, TOPIC_TF, TOPIC_TRUTH_JOINTS,
    TOPIC_TRUTH_ODOM, TOPIC_WHEEL_CMD,
};
use serde_json::Value;
use std::collections::BTreeSet;

const LAYOUT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/foxglove/drive-sim.layout.json");

/// The topic of a Foxglove message path (`/topic.field[0]`) or topic name.
fn topic_of(path: &str) -> String {
    let end = path.find(['.', '[', '{']).unwrap_or(path.len());
    path[..end].to_string()
}

fn collect(v: &Value, out: &mut BTreeSet<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                match (k.as_str(), x) {
                    ("value" | "topicPath", Value::String(s)) if s.starts_with('/') => {
                        out.insert(topic_of(s));
                    }
                    ("topics", Value::Object(t)) => out.extend(t.keys().cloned()),
                    _ => collect(x, out),
                }
            }
        }
        Value::Array(a) => a.iter().for_each(|x| collect(x, out)),
        _ => {}
    }
}

#[test]
fn layout_panels_read_the_logged_topics() {
    let layout: Value = serde_json::from_str(&std::fs::read_to_string(LAYOUT).unwrap()).unwrap();
    let mut used = BTreeSet::new();
    collect(&layout["configById"], &mut used);
    let written: BTreeSet<String> = [
        TOPIC_MARKER,
        TOPIC_CMD_VEL,
        TOPIC_WHEEL_CMD,
        TOPIC_JOINT_STATES,
        TOPIC_ICP_ODOM,
        TOPIC_IMU,
        TOPIC_TF,
        TOPIC_TRUTH_ODOM,
        TOPIC_TRUTH_JOINTS,
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let unknown: Vec<_> = used.difference(&written).collect();
    assert!(
        unknown.is_empty(),
        "panels read topics drive-sim does not write: {unknown:?}"
    );
    // /tf drives the 3D panel's frames without being a panel topic.
    let unshown: Vec<_> = written
        .difference(&used)
        .filter(|t| t.as_str() != TOPIC_TF)
        .collect();
    assert!(unshown.is_empty(), "logged topics on no panel: {unshown:?}");
    // Every panel of the mosaic is configured, and every configured panel is placed.
    let mut placed = BTreeSet::new();
    fn leaves(v: &Value, out: &mut BTreeSet<String>) {
        match v {
            Value::String(s) => {
                out.insert(s.clone());
            }
            Value::Object(m) => {
                for k in ["first", "second"] {
                    if let Some(x) = m.get(k) {
                        leaves(x, out);
                    }
                }
            }
            _ => {}
        }
    }
    leaves(&layout["layout"], &mut placed);
    let configured: BTreeSet<String> = layout["configById"]
        .as_object()
        .unwrap()
        .keys()
        .cloned()
        .collect();
    assert_eq!(placed, configured);
}
