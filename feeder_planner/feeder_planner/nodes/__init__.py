"""ROS 2 planner nodes: thin rclpy adapters around the feeder_planner mechanics."""
