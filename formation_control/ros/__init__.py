"""ROS 2 (rclpy) nodes: thin wrappers that turn messages into core arrays and back."""
