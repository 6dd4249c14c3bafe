#!/usr/bin/env python3
"""Writes a measured DRIVE CSV as the rosbag2 bag the DRIVE ROS 2 node records.

An independent writer for tests/quick/bag_read.rs: the `rosbags` package (pip install rosbags)
serializes the messages and writes the storage (sqlite3 or MCAP), so the Rust reader is checked
against a bag it did not write itself.

Topics are the Warthog's (roles/warthog.toml): /doughnut_cmd_vel (Twist, the body command from
the CSV's wheel command through the nominal IDD), /left_drive/status/speed and
/right_drive/status/speed (Float64 encoders), /icp_odom (Odometry: the CSV's window-local ICP
poses chained into one continuous odom frame, twist = the CSV's own velocity estimate),
/MTI_imu/data_unbiased (Imu), /calib_step (Int32) and /calib_state (String), all at 20 Hz, plus
a point-cloud topic the reader must skip. Steps follow each other as the DRIVE node runs them
(6 s each, no pause); `--interrupt S` first runs 2 s of step S, stops 1 s in `idle` with a zero
command, then runs the whole step.

Compression: `--compression file|message` writes the bag as `ros2 bag record
--compression-mode file|message --compression-format zstd` does (rosbags' writer).
`--mcap-chunks zstd` has rosbags compress the MCAP chunks themselves (MCAP's own chunk
compression, not rosbag2's); `--mcap-chunks lz4` and `--mcap-no-summary` rewrite the MCAP file
with the Python `mcap` writer (pip install mcap): lz4-compressed chunks, or no summary section
(no chunk or message indexes, as a recorder that did not close its file cleanly leaves).

Exit code 3: rosbags (or, for the rewrites, mcap) is not installed.
"""

import argparse
import csv
import json
import math
import sys
from pathlib import Path

try:
    import numpy as np
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore
except ImportError as e:  # pragma: no cover
    print(f"write_drive_bag.py: {e}: pip install rosbags", file=sys.stderr)
    sys.exit(3)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("out")
    ap.add_argument("--storage", choices=["sqlite3", "mcap"], default="sqlite3")
    ap.add_argument("--steps", type=int, default=0, help="first N steps only (0: all)")
    ap.add_argument("--no-step-topic", action="store_true", help="no /calib_step, /calib_state")
    ap.add_argument("--interrupt", type=int, default=-1, help="step with an interrupted first attempt")
    ap.add_argument("--gap", type=int, default=-1, help="step where the IMU is silent for 3 s")
    ap.add_argument("--drop", default="", help="topic not written at all")
    ap.add_argument("--wrong-type", default="", help="topic written as std_msgs/Float64")
    ap.add_argument("--rename", action="append", default=[], metavar="OLD=NEW", help="write topic OLD as NEW (as a lab's remapping does)")
    ap.add_argument("--repeat", type=int, default=1, help="write the steps this many times")
    ap.add_argument("--cloud-bytes", type=int, default=2000, help="point cloud message size")
    ap.add_argument("--cloud-hz", type=float, default=1.0)
    ap.add_argument("--params", action="store_true", help="write the DRIVE node's YAML beside")
    ap.add_argument("--compression", choices=["none", "file", "message"], default="none", help="rosbag2 zstd compression mode")
    ap.add_argument("--mcap-chunks", choices=["none", "zstd", "lz4"], default="none", help="MCAP chunk compression")
    ap.add_argument("--mcap-no-summary", action="store_true", help="MCAP without a summary section")
    a = ap.parse_args()
    if (a.mcap_chunks != "none" or a.mcap_no_summary) and a.storage != "mcap":
        ap.error("--mcap-chunks and --mcap-no-summary need --storage mcap")
    if a.compression == "file" and (a.mcap_chunks == "lz4" or a.mcap_no_summary):
        ap.error("the MCAP rewrites work on an uncompressed file")

    meta = json.loads(Path(a.csv).with_suffix(".json").read_text())
    nom = meta["nominal"]
    r, b = nom["wheel_radius_m"], nom["baseline_m"]
    rows = list(csv.DictReader(open(a.csv)))
    steps = {}
    for row in rows:
        steps.setdefault(int(row["step"]), []).append(row)
    order = sorted(steps)
    if a.steps:
        order = order[: a.steps]
    order = order * a.repeat

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    Twist, Vector3 = T["geometry_msgs/msg/Twist"], T["geometry_msgs/msg/Vector3"]
    Float64, Int32, String = T["std_msgs/msg/Float64"], T["std_msgs/msg/Int32"], T["std_msgs/msg/String"]
    Odometry, Imu = T["nav_msgs/msg/Odometry"], T["sensor_msgs/msg/Imu"]
    Header, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    PoseWC, Pose = T["geometry_msgs/msg/PoseWithCovariance"], T["geometry_msgs/msg/Pose"]
    Point, Quat = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    TwistWC = T["geometry_msgs/msg/TwistWithCovariance"]
    Cloud, Field = T["sensor_msgs/msg/PointCloud2"], T["sensor_msgs/msg/PointField"]

    plugin = StoragePlugin.SQLITE3 if a.storage == "sqlite3" else StoragePlugin.MCAP
    out = Path(a.out)
    w = Writer(out, version=8, storage_plugin=plugin)
    if a.compression != "none":
        mode = CompressionMode.FILE if a.compression == "file" else CompressionMode.MESSAGE
        w.set_compression(mode, CompressionFormat.ZSTD)
    elif a.mcap_chunks == "zstd":
        w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with w:
        conns = {}
        renamed = dict(r.split("=", 1) for r in a.rename)

        def conn(topic, msgtype):
            if topic == a.drop:
                return None
            if topic == a.wrong_type:
                msgtype = "std_msgs/msg/Float64"
            if topic not in conns:
                name = renamed.get(topic, topic)
                conns[topic] = (w.add_connection(name, msgtype, typestore=ts), msgtype)
            return conns[topic]

        def put(topic, msgtype, msg, t_ns):
            c = conn(topic, msgtype)
            if c is None:
                return
            if c[1] != msgtype:
                msg, msgtype = Float64(data=0.0), c[1]
            w.write(c[0], t_ns, ts.serialize_cdr(msg, msgtype))

        t0 = 1_700_000_000_000_000_000
        tick = 50_000_000
        t = t0
        # Continuous odom frame: each window's local poses are chained onto the last pose.
        wx = wy = wyaw = 0.0
        last_d = (0.0, 0.0, 0.0)
        cloud_next = t0
        n_pts = max(a.cloud_bytes // 16, 1)
        cloud_data = np.frombuffer(bytes((i * 7) % 251 for i in range(16 * n_pts)), dtype=np.uint8)

        def header(t_ns, frame):
            return Header(stamp=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id=frame)

        def tick_msgs(t_ns, step_idx, state, cmd, row, pose):
            nonlocal cloud_next
            vx = r * (cmd[0] + cmd[1]) / 2
            wz = r * (cmd[1] - cmd[0]) / b
            if not a.no_step_topic:
                put("/calib_state", "std_msgs/msg/String", String(data=state), t_ns)
                put("/calib_step", "std_msgs/msg/Int32", Int32(data=step_idx), t_ns)
            put(
                "/doughnut_cmd_vel",
                "geometry_msgs/msg/Twist",
                Twist(linear=Vector3(x=vx, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=wz)),
                t_ns,
            )
            if row is None:
                return
            put("/left_drive/status/speed", "std_msgs/msg/Float64", Float64(data=float(row["enc_left_rad_s"])), t_ns)
            put("/right_drive/status/speed", "std_msgs/msg/Float64", Float64(data=float(row["enc_right_rad_s"])), t_ns)
            x, y, z, roll, pitch, yaw = pose
            cr, sr = math.cos(roll / 2), math.sin(roll / 2)
            cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
            cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
            q = Quat(
                x=sr * cp * cy - cr * sp * sy,
                y=cr * sp * cy + sr * cp * sy,
                z=cr * cp * sy - sr * sp * cy,
                w=cr * cp * cy + sr * sp * sy,
            )
            ref = [row["ref_vx_m_s"], row["ref_vy_m_s"], row["ref_wz_rad_s"]]
            ref = [float(v) if v != "" else float("nan") for v in ref]
            odom = Odometry(
                header=header(t_ns, "odom"),
                child_frame_id="base_link",
                pose=PoseWC(pose=Pose(position=Point(x=x, y=y, z=z), orientation=q), covariance=np.zeros(36)),
                twist=TwistWC(
                    twist=Twist(linear=Vector3(x=ref[0], y=ref[1], z=0.0), angular=Vector3(x=0.0, y=0.0, z=ref[2])),
                    covariance=np.zeros(36),
                ),
            )
            put("/icp_odom", "nav_msgs/msg/Odometry", odom, t_ns)
            if not (a.gap == step_idx and 40 * tick <= t_ns - step_start <= 100 * tick):
                cov = np.zeros(9)
                cov[0] = -1.0
                imu = Imu(
                    header=header(t_ns, "imu_link"),
                    orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0),
                    orientation_covariance=cov,
                    angular_velocity=Vector3(x=0.0, y=0.0, z=float(row["imu_wz_rad_s"])),
                    angular_velocity_covariance=np.zeros(9),
                    linear_acceleration=Vector3(
                        x=float(row["imu_ax_m_s2"]), y=float(row["imu_ay_m_s2"]), z=float(row["imu_az_m_s2"])
                    ),
                    linear_acceleration_covariance=np.zeros(9),
                )
                put("/MTI_imu/data_unbiased", "sensor_msgs/msg/Imu", imu, t_ns)
            while cloud_next <= t_ns:
                cloud = Cloud(
                    header=header(cloud_next, "lidar"),
                    height=1,
                    width=n_pts,
                    fields=[Field(name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate("xyzi")],
                    is_bigendian=False,
                    point_step=16,
                    row_step=16 * n_pts,
                    data=cloud_data,
                    is_dense=True,
                )
                put("/rslidar_points", "sensor_msgs/msg/PointCloud2", cloud, cloud_next)
                cloud_next += int(1e9 / a.cloud_hz)

        # A second of idle before the protocol starts.
        for _ in range(20):
            tick_msgs(t, 0, "idle", (0.0, 0.0), None, None)
            t += tick
        step_start = t
        for n, s in enumerate(order):
            rs = steps[s]
            attempts = [40, len(rs)] if n == a.interrupt else [len(rs)]
            for m in attempts:
                step_start = t
                prev_local = None
                for i, row in enumerate(rs[:m]):
                    local = [float(row[k]) for k in ("icp_x_m", "icp_y_m", "icp_z_m", "icp_roll_rad", "icp_pitch_rad", "icp_yaw_rad")]
                    if int(row["k"]) == 0 or prev_local is None:
                        # New window frame: anchor it one tick ahead of the last odom pose, at the
                        # last tick's displacement, so the odom path stays smooth across windows.
                        ax, ay, ayaw = wx + last_d[0], wy + last_d[1], wyaw + last_d[2]
                        base = local
                    dx, dy = local[0] - base[0], local[1] - base[1]
                    c, si = math.cos(ayaw - base[5]), math.sin(ayaw - base[5])
                    wx_, wy_ = ax + c * dx - si * dy, ay + si * dx + c * dy
                    wyaw_ = math.atan2(math.sin(ayaw + local[5] - base[5]), math.cos(ayaw + local[5] - base[5]))
                    # The command as the CSV recorded it: a step's first tick may still carry the
                    # previous one.
                    row_cmd = (float(row["cmd_left_rad_s"]), float(row["cmd_right_rad_s"]))
                    tick_msgs(t, n, "calib", row_cmd, row, (wx_, wy_, local[2], local[3], local[4], wyaw_))
                    prev_local = local
                    last_d = (wx_ - wx, wy_ - wy, math.atan2(math.sin(wyaw_ - wyaw), math.cos(wyaw_ - wyaw)))
                    wx, wy, wyaw = wx_, wy_, wyaw_
                    t += tick
                if m < len(rs):
                    for _ in range(20):
                        tick_msgs(t, n, "idle", (0.0, 0.0), rs[0], (wx, wy, 0.0, 0.0, 0.0, wyaw))
                        t += tick
        for _ in range(20):
            tick_msgs(t, len(order), "idle", (0.0, 0.0), None, None)
            t += tick

    if a.mcap_chunks == "lz4" or a.mcap_no_summary:
        rewrite_mcap(next(out.glob("*.mcap")), a.mcap_chunks == "lz4", not a.mcap_no_summary)

    if a.params:
        (out if out.is_dir() else out.parent).joinpath("drive.config.yaml").write_text(
            "drive_node:\n  ros__parameters:\n"
            f"    cmd_rate: 20\n    max_lin_speed: {nom['max_lin_m_s']}\n    max_ang_speed: {nom['max_ang_rad_s']}\n"
            f"    step_len: 6.0\n    wheel_radius: {r}\n    wheel_baseline: {b}\n"
        )


def rewrite_mcap(path, lz4, summary):
    """Rewrites an MCAP file with the Python mcap writer: lz4 chunks, or no summary section."""
    try:
        from mcap.reader import make_reader
        from mcap.writer import CompressionType, IndexType
        from mcap.writer import Writer as McapWriter
    except ImportError as e:  # pragma: no cover
        print(f"write_drive_bag.py: {e}: pip install mcap", file=sys.stderr)
        sys.exit(3)
    tmp = path.with_suffix(".tmp")
    with open(path, "rb") as src, open(tmp, "wb") as dst:
        r = make_reader(src)
        header = r.get_header()
        if summary:
            w = McapWriter(dst, compression=CompressionType.LZ4 if lz4 else CompressionType.NONE)
        else:
            w = McapWriter(
                dst,
                compression=CompressionType.LZ4 if lz4 else CompressionType.NONE,
                index_types=IndexType.NONE,
                repeat_channels=False,
                repeat_schemas=False,
                use_statistics=False,
                use_summary_offsets=False,
            )
        w.start(profile=header.profile, library=header.library)
        schemas, channels = {}, {}
        for schema, channel, msg in r.iter_messages(log_time_order=False):
            if schema.id not in schemas:
                schemas[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = w.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id], channel.metadata
                )
            w.add_message(channels[channel.id], msg.log_time, msg.data, msg.publish_time, msg.sequence)
        for m in r.iter_metadata():
            w.add_metadata(m.name, m.metadata)
        w.finish()
    tmp.replace(path)


if __name__ == "__main__":
    main()
