//! ROS 2 MCAP writer and reader for DRIVE logs.
//!
//! [`McapWriter`] streams [`Frame`]s into an MCAP file that Foxglove, `ros2 bag` (with the MCAP
//! storage plugin) and the official `mcap` readers decode as ROS 2 messages: profile `ros2`,
//! schemas `ros2msg` with every dependency embedded as rosbag2 writes them, messages in CDR.
//! [`read_mcap`] decodes such a file back into the same [`DriveLog`] the in-memory frames give.
//!
//! # Topics
//! One message per topic per frame (20 Hz in the DRIVE protocol), all stamped with the frame's
//! time:
//!
//! | topic | type | content |
//! |---|---|---|
//! | `/drive/marker` | `drive_sim_msgs/msg/DriveMarker` | protocol phase (`step`/`reorient`/`idle`), step, attempt, window, k, time in step, exact log time |
//! | `/cmd_vel` | `geometry_msgs/msg/TwistStamped` | body command: the wheel command through the declared IDD ([`Nominal::idd`](super::Nominal::idd)), frame `base_link` |
//! | `/wheel_cmd` | `sensor_msgs/msg/JointState` | commanded wheel speeds, `velocity` in rad/s for joints `left_wheel`, `right_wheel` |
//! | `/joint_states` | `sensor_msgs/msg/JointState` | encoder wheel speeds, same joints (no position or effort) |
//! | `/icp_odom` | `nav_msgs/msg/Odometry` | lidar/ICP pose, frame `odom`, child `base_link`; twist = the source's own body-velocity estimate, or NaN with `twist.covariance[0] = -1` when it has none |
//! | `/imu/data_raw` | `sensor_msgs/msg/Imu` | yaw rate and specific force in `base_link`; no orientation (`orientation_covariance[0] = -1`), other covariances 0 (unknown) |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | `odom`→`base_link` from the lidar pose, and `odom`→`base_link_truth` from the ground truth when there is one |
//! | `/ground_truth/odom` | `nav_msgs/msg/Odometry` | simulated logs only: true pose in `odom`, true twist in the body frame (child `base_link`) |
//! | `/ground_truth/joint_states` | `sensor_msgs/msg/JointState` | simulated logs only: true wheel speeds |
//!
//! Every channel carries rosbag2's `offered_qos_profiles` metadata ([`OFFERED_QOS_PROFILES`]),
//! and the custom marker type ships as a ROS 2 interface package in `msg/drive_sim_msgs` (build
//! it in a ROS 2 workspace to play the marker topic back with `ros2 bag play`).
//!
//! The [`LogMeta`] is an MCAP metadata record named [`METADATA_NAME`] with keys `format`
//! ([`FORMAT`]) and `log_meta` (JSON).
//!
//! # Time
//! `log_time`, `publish_time` and header stamps are `1 s + stamp_s`, in ns: fixed, never wall
//! clock, and never 0 (tf treats a zero stamp as "latest"). The marker also carries `stamp_s`
//! exactly as an f64, so reading gives back the very same stamps. Frame stamps must increase
//! strictly: the reader matches the messages of one frame by their log time.
//!
//! # Exactness
//! Every value read back is bit-identical to the value written, except roll, pitch and yaw:
//! ROS carries attitude as a quaternion, and Euler → quaternion → Euler is exact only to about
//! 1e-15 rad (yaw ±π may come back as ∓π).
//!
//! # File
//! Chunked (1 MiB chunks), zstd-compressed (the `mcap` crate's default codec; Foxglove, the Go
//! CLI and the Python `mcap` package all read it, the latter through its `zstandard`
//! dependency), with chunk and message indexes, CRCs and a summary, so readers can seek and
//! check. [`container`] writes the records (one zstd call per chunk instead of the crate's
//! seven streaming calls per message); they are the records the crate's writer produces,
//! which `tests/quick/mcap_roundtrip.rs` checks record by record. Output is a
//! deterministic function of the frames: no clock, no hash ordering, single-threaded zstd.
//! The writer writes `<path>.partial` and renames it to `<path>` only in
//! [`McapWriter::finish`]: a crashed or failed run leaves no complete-looking log behind.

//!
//! # Code
//! [`write`](mod@write) turns frames into messages, [`container`] writes them as the file,
//! [`read`] decodes the file back, and
//! [`convert`] holds the one mapping between the domain types and the ROS messages, used both
//! ways.

pub mod container;
pub mod convert;
pub mod read;
pub mod write;

pub use container::Container;
pub use read::{decode_mcap, read_mcap, read_mcap_frames};
pub use write::{encode_mcap, encode_mcap_with, interrupted_path, partial_path, write_mcap, McapWriter};

#[cfg(doc)]
use crate::{DriveLog, Frame, LogMeta};
use drive_sim_model::error::Error;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Protocol phase marker topic.
pub const TOPIC_MARKER: &str = "/drive/marker";
/// Body command topic.
pub const TOPIC_CMD_VEL: &str = "/cmd_vel";
/// Wheel command topic.
pub const TOPIC_WHEEL_CMD: &str = "/wheel_cmd";
/// Encoder topic.
pub const TOPIC_JOINT_STATES: &str = "/joint_states";
/// Lidar/ICP odometry topic.
pub const TOPIC_ICP_ODOM: &str = "/icp_odom";
/// IMU topic.
pub const TOPIC_IMU: &str = "/imu/data_raw";
/// Transform tree topic.
pub const TOPIC_TF: &str = "/tf";
/// Ground-truth odometry topic (simulated logs).
pub const TOPIC_TRUTH_ODOM: &str = "/ground_truth/odom";
/// Ground-truth wheel speed topic (simulated logs).
pub const TOPIC_TRUTH_JOINTS: &str = "/ground_truth/joint_states";

/// Name of the metadata record holding the [`LogMeta`].
pub const METADATA_NAME: &str = "drive_sim";
/// Value of the metadata `format` key; bumped when the topic layout changes.
pub const FORMAT: &str = "drive-sim-mcap/1";
/// Channel metadata key under which rosbag2 stores the QoS the recorded publishers offered.
pub const QOS_METADATA_KEY: &str = "offered_qos_profiles";
/// The QoS every channel declares, in rosbag2's own form (Humble and later, integer enums): one
/// publisher, reliable (1), volatile (2), liveliness automatic (1), infinite durations, and
/// history/depth unknown (3/0) as rosbag2 records them from the graph. `ros2 bag play` reads it
/// to re-publish each topic with a compatible QoS (without it, it falls back to defaults and
/// warns); `/tf` is volatile like any other topic, so no transient-local override is needed.
pub const OFFERED_QOS_PROFILES: &str = "- history: 3
  depth: 0
  reliability: 1
  durability: 2
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: 1
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false";
/// Offset added to `stamp_s` in every MCAP and header time, ns.
pub const EPOCH_OFFSET_NS: u64 = 1_000_000_000;

/// Fixed frame of poses.
pub const FRAME_ODOM: &str = "odom";
/// Body frame.
pub const FRAME_BASE: &str = "base_link";
/// Body frame of the ground truth in `/tf`.
pub const FRAME_BASE_TRUTH: &str = "base_link_truth";
/// Joint name of the left wheels.
pub const JOINT_LEFT: &str = "left_wheel";
/// Joint name of the right wheels.
pub const JOINT_RIGHT: &str = "right_wheel";

/// What [`McapWriter::finish`] reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct McapSummary {
    /// The finished log.
    pub path: PathBuf,
    /// Frames written.
    pub frames: u64,
    /// Messages per topic (every topic of the file, in name order).
    pub messages_per_topic: BTreeMap<String, u64>,
    /// File size, bytes.
    pub bytes: u64,
}

fn mcap_err(file: &Path, location: &str, e: mcap::McapError) -> Error {
    Error::log(file, location, format!("MCAP: {e}"))
}
