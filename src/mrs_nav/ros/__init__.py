"""ROS adapters: message conversion and one ``<Thing>Node`` class per node; the only code importing rospy."""
