"""ROS 2 simulator nodes: thin rclpy adapters around the feeder_sim models."""
