"""The ROS 2 node (rclpy adapter); imports rclpy."""
