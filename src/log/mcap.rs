//! ROS 2 MCAP writer and reader.
