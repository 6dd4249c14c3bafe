//! The message declarations: standard ROS 2 types the DRIVE logs and the DRIVE node's bags use,
//! and drive-sim's own protocol marker.

ros_message! {
    /// `builtin_interfaces/Time`.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
    pub struct Time (TIME, "builtin_interfaces/Time") {
        /// Seconds.
        sec: i32,
        /// Nanoseconds, < 1e9.
        nanosec: u32,
    }
}

impl Time {
    /// From nanoseconds since the epoch; `None` beyond 2038 (`int32` seconds).
    pub fn from_ns(ns: u64) -> Option<Self> {
        Some(Self {
            sec: i32::try_from(ns / 1_000_000_000).ok()?,
            nanosec: (ns % 1_000_000_000) as u32,
        })
    }

    /// Nanoseconds since the epoch; `None` if negative or `nanosec` is out of range.
    pub fn to_ns(self) -> Option<u64> {
        if self.sec < 0 || self.nanosec >= 1_000_000_000 {
            return None;
        }
        Some(self.sec as u64 * 1_000_000_000 + self.nanosec as u64)
    }
}

ros_message! {
    /// `std_msgs/Header`.
    #[derive(Debug, Clone, PartialEq, Eq, Default)]
    pub struct Header (HEADER, "std_msgs/Header") {
        /// Time of the data.
        stamp: Time,
        /// Frame the data is expressed in.
        frame_id: String,
    }
}

ros_message! {
    /// `std_msgs/Float64` (the DRIVE node's per-side wheel speeds).
    #[derive(Debug, Clone, Copy, PartialEq, Default)]
    pub struct Float64 (FLOAT64, "std_msgs/Float64") {
        /// The value.
        data: f64,
    }
}

ros_message! {
    /// `std_msgs/Int32` (the DRIVE node's step index, `calib_step`).
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
    pub struct Int32 (INT32, "std_msgs/Int32") {
        /// The value.
        data: i32,
    }
}

ros_message! {
    /// `std_msgs/String` (the DRIVE node's state, `calib_state`).
    #[derive(Debug, Clone, PartialEq, Eq, Default)]
    pub struct StringMsg (STRING, "std_msgs/String") {
        /// The value.
        data: String,
    }
}

ros_message! {
    /// `std_msgs/Bool`.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
    pub struct Bool (BOOL, "std_msgs/Bool") {
        /// The value.
        data: bool,
    }
}

ros_message! {
    /// `geometry_msgs/Vector3`.
    #[derive(Debug, Clone, Copy, PartialEq, Default)]
    pub struct Vector3 (VECTOR3, "geometry_msgs/Vector3") {
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// z.
        z: f64,
    }
}

ros_message! {
    /// `geometry_msgs/Point`.
    #[derive(Debug, Clone, Copy, PartialEq, Default)]
    pub struct Point (POINT, "geometry_msgs/Point") {
        /// x, m.
        x: f64,
        /// y, m.
        y: f64,
        /// z, m.
        z: f64,
    }
}

ros_message! {
    /// `geometry_msgs/Quaternion` (with the ROS 2 default values).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct Quaternion (QUATERNION, "geometry_msgs/Quaternion") {
        /// x.
        x: f64 = "0",
        /// y.
        y: f64 = "0",
        /// z.
        z: f64 = "0",
        /// w.
        w: f64 = "1",
    }
}

impl Default for Quaternion {
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

ros_message! {
    /// `geometry_msgs/Twist`.
    #[derive(Debug, Clone, Copy, PartialEq, Default)]
    pub struct Twist (TWIST, "geometry_msgs/Twist") {
        /// Linear velocity, m/s.
        linear: Vector3,
        /// Angular velocity, rad/s.
        angular: Vector3,
    }
}

ros_message! {
    /// `geometry_msgs/TwistStamped`.
    #[derive(Debug, Clone, PartialEq, Default)]
    pub struct TwistStamped (TWIST_STAMPED, "geometry_msgs/TwistStamped") {
        /// Header.
        header: Header,
        /// Twist.
        twist: Twist,
    }
}

ros_message! {
    /// `geometry_msgs/Pose`.
    #[derive(Debug, Clone, Copy, PartialEq, Default)]
    pub struct Pose (POSE, "geometry_msgs/Pose") {
        /// Position, m.
        position: Point,
        /// Orientation.
        orientation: Quaternion,
    }
}

ros_message! {
    /// `geometry_msgs/PoseWithCovariance`.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct PoseWithCovariance (POSE_WITH_COVARIANCE, "geometry_msgs/PoseWithCovariance") {
        /// Pose.
        pose: Pose,
        /// Row-major covariance (x, y, z, rot x, rot y, rot z).
        covariance: [f64; 36],
    }
}

ros_message! {
    /// `geometry_msgs/TwistWithCovariance`.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct TwistWithCovariance (TWIST_WITH_COVARIANCE, "geometry_msgs/TwistWithCovariance") {
        /// Twist.
        twist: Twist,
        /// Row-major covariance.
        covariance: [f64; 36],
    }
}

ros_message! {
    /// `nav_msgs/Odometry`.
    #[derive(Debug, Clone, PartialEq)]
    pub struct Odometry (ODOMETRY, "nav_msgs/Odometry") {
        /// Header; `frame_id` is the frame of the pose.
        header: Header,
        /// Frame of the twist.
        child_frame_id: String,
        /// Pose in `header.frame_id`.
        pose: PoseWithCovariance,
        /// Twist in `child_frame_id`.
        twist: TwistWithCovariance,
    }
}

ros_message! {
    /// `sensor_msgs/JointState`.
    #[derive(Debug, Clone, PartialEq, Default)]
    pub struct JointState (JOINT_STATE, "sensor_msgs/JointState") {
        /// Header.
        header: Header,
        /// Joint names.
        name: Vec<String>,
        /// Positions, rad (empty when not measured).
        position: Vec<f64>,
        /// Velocities, rad/s.
        velocity: Vec<f64>,
        /// Efforts, N m (empty when not measured).
        effort: Vec<f64>,
    }
}

ros_message! {
    /// `sensor_msgs/Imu`.
    #[derive(Debug, Clone, PartialEq)]
    pub struct Imu (IMU, "sensor_msgs/Imu") {
        /// Header.
        header: Header,
        /// Orientation (meaningless when `orientation_covariance[0] == -1`).
        orientation: Quaternion,
        /// Row-major covariance; element 0 = -1 means "no orientation estimate".
        orientation_covariance: [f64; 9],
        /// Angular velocity, rad/s.
        angular_velocity: Vector3,
        /// Covariance (all zero: unknown).
        angular_velocity_covariance: [f64; 9],
        /// Linear acceleration (specific force), m/s².
        linear_acceleration: Vector3,
        /// Covariance (all zero: unknown).
        linear_acceleration_covariance: [f64; 9],
    }
}

ros_message! {
    /// `geometry_msgs/Transform`.
    #[derive(Debug, Clone, Copy, PartialEq, Default)]
    pub struct Transform (TRANSFORM, "geometry_msgs/Transform") {
        /// Translation, m.
        translation: Vector3,
        /// Rotation.
        rotation: Quaternion,
    }
}

ros_message! {
    /// `geometry_msgs/TransformStamped`.
    #[derive(Debug, Clone, PartialEq, Default)]
    pub struct TransformStamped (TRANSFORM_STAMPED, "geometry_msgs/TransformStamped") {
        /// Header; `frame_id` is the parent frame.
        header: Header,
        /// The child frame.
        child_frame_id: String,
        /// Child in parent.
        transform: Transform,
    }
}

ros_message! {
    /// `tf2_msgs/TFMessage`.
    #[derive(Debug, Clone, PartialEq, Default)]
    pub struct TfMessage (TF_MESSAGE, "tf2_msgs/TFMessage") {
        /// Transforms.
        transforms: Vec<TransformStamped>,
    }
}

ros_message! {
    /// `drive_sim_msgs/DriveMarker`: where the DRIVE protocol is at one logged tick (its `.msg`
    /// file ships in `msg/drive_sim_msgs/msg/DriveMarker.msg`).
    #[derive(Debug, Clone, PartialEq, Default)]
    pub struct DriveMarker (DRIVE_MARKER, "drive_sim_msgs/DriveMarker")
        comment "Where the DRIVE protocol is at one logged tick (drive-sim)."
    {
        /// Header (frame_id empty: the marker is not spatial).
        header: Header,
        /// `step`, `reorient` or `idle`.
        #[comment = "\"step\" (executing a command), \"reorient\" (after an interruption) or \"idle\"."]
        phase: String,
        /// Step index.
        #[comment = "Step index (the interrupted step while re-orienting; 0 when idle)."]
        step: u32,
        /// Attempt index.
        #[comment = "Attempt of this step, from 0; an interruption starts a new attempt (0 unless step)."]
        attempt: u32,
        /// Window index.
        #[comment = "Window index: 0 transient, 1.. steady (0 unless step)."]
        window: u32,
        /// Sample index in the window.
        #[comment = "Sample index inside the window (0 unless step)."]
        k: u32,
        /// Time since the start of the attempt, s.
        #[comment = "Time since the start of the attempt, s (0 unless step)."]
        t_in_step: f64,
        /// Exact log time, s.
        #[comment = "Log time, s, exactly as the simulator produced it (the header stamp is this plus a"]
        #[comment = "1 s offset, rounded to the nanosecond)."]
        stamp: f64,
    }
}
