"""ROS 1 adapters: message conversions and one node class per node. The only code importing rospy and tf2."""
