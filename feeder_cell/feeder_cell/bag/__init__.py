"""Recording and replaying rosbag2 MCAP bags with rclpy and rosbags (ros2bag is not available here)."""
