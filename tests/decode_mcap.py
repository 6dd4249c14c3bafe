#!/usr/bin/env python3
"""Decodes every message of a drive-sim MCAP log with the official readers and prints a JSON
summary, so that tests/quick/mcap_python.rs can check the Rust writer against an independent decoder.

Needs: pip install mcap mcap-ros2-support

Output: {"profile", "library", "metadata": {name: {key: value}},
         "topics": {topic: {"schema", "encoding", "count", "first", "last", "sums",
                            "first_log_time_ns", "last_log_time_ns"}}}
where "first"/"last" are a few decoded fields of the first/last message and "sums" adds some
fields over every message in file order (Python floats are IEEE doubles, so the Rust side can
reproduce the sums bit for bit).
"""

import json
import math
import sys

try:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
except ImportError as e:  # pragma: no cover - reported to the Rust test
    print(
        f"decode_mcap.py: missing Python package ({e}); "
        "install with: pip install mcap mcap-ros2-support",
        file=sys.stderr,
    )
    sys.exit(3)


def finite_or_none(x):
    """JSON has no NaN: unknown values become null."""
    return x if math.isfinite(x) else None


def stamp_ns(header):
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def fields(topic, schema, m):
    """A few fields of one decoded message, and the values to add into the topic's sums."""
    if schema == "drive_sim_msgs/msg/DriveMarker":
        f = {
            "phase": m.phase,
            "step": m.step,
            "attempt": m.attempt,
            "window": m.window,
            "k": m.k,
            "t_in_step": m.t_in_step,
            "stamp": m.stamp,
            "header_stamp_ns": stamp_ns(m.header),
        }
        return f, {"step": m.step, "t_in_step": m.t_in_step, "stamp": m.stamp}
    if schema == "geometry_msgs/msg/TwistStamped":
        f = {
            "frame_id": m.header.frame_id,
            "linear_x": m.twist.linear.x,
            "angular_z": m.twist.angular.z,
            "header_stamp_ns": stamp_ns(m.header),
        }
        return f, {"linear_x": m.twist.linear.x, "angular_z": m.twist.angular.z}
    if schema == "sensor_msgs/msg/JointState":
        f = {"name": list(m.name), "velocity": list(m.velocity), "position": list(m.position)}
        return f, {"left": m.velocity[0], "right": m.velocity[1]}
    if schema == "nav_msgs/msg/Odometry":
        p = m.pose.pose
        f = {
            "frame_id": m.header.frame_id,
            "child_frame_id": m.child_frame_id,
            "x": p.position.x,
            "y": p.position.y,
            "qz": p.orientation.z,
            "qw": p.orientation.w,
            "twist_linear_x": finite_or_none(m.twist.twist.linear.x),
            "twist_covariance0": m.twist.covariance[0],
        }
        return f, {"x": p.position.x, "y": p.position.y}
    if schema == "sensor_msgs/msg/Imu":
        f = {
            "frame_id": m.header.frame_id,
            "wz": m.angular_velocity.z,
            "ay": m.linear_acceleration.y,
            "az": m.linear_acceleration.z,
            "orientation_covariance0": m.orientation_covariance[0],
        }
        return f, {"wz": m.angular_velocity.z, "az": m.linear_acceleration.z}
    if schema == "tf2_msgs/msg/TFMessage":
        f = {
            "parents": [t.header.frame_id for t in m.transforms],
            "children": [t.child_frame_id for t in m.transforms],
            "x": [t.transform.translation.x for t in m.transforms],
        }
        return f, {"x": m.transforms[0].transform.translation.x}
    raise SystemExit(f"decode_mcap.py: unexpected schema {schema} on {topic}")


def main(path):
    out = {"metadata": {}, "topics": {}}
    with open(path, "rb") as stream:
        # validate_crcs: the chunk, data-section and summary CRCs our container writes are checked.
        reader = make_reader(stream, validate_crcs=True, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        out["profile"] = header.profile
        out["library"] = header.library
        for record in reader.iter_metadata():
            out["metadata"][record.name] = dict(record.metadata)
        # Every message of every topic, decoded: an undecodable one raises.
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            f, s = fields(channel.topic, schema.name, decoded)
            t = out["topics"].setdefault(
                channel.topic,
                {
                    "schema": schema.name,
                    "encoding": [schema.encoding, channel.message_encoding],
                    "count": 0,
                    "first": f,
                    "first_log_time_ns": message.log_time,
                    "sums": {k: 0.0 for k in s},
                },
            )
            t["count"] += 1
            t["last"] = f
            t["last_log_time_ns"] = message.log_time
            for k, v in s.items():
                t["sums"][k] += v
    print(json.dumps(out, indent=1, allow_nan=False))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit("usage: decode_mcap.py <file.mcap>")
    main(sys.argv[1])
