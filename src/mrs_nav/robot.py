"""The TurtleBot3 Burger's size and limits, written once for the whole package.

Values from the Burger's specification: a 0.105 m footprint radius (the default inflation of every planner and
the simulated chassis), 0.22 m/s and 2.84 rad/s top speeds (what the simulator obeys and the followers
saturate to).
"""

#: Footprint radius (m).
BURGER_RADIUS = 0.105
#: Overall height (m): a world's obstacle must reach below it to stand in the robot's way.
BURGER_HEIGHT = 0.192
#: Top linear speed (m/s).
BURGER_MAX_LINEAR = 0.22
#: Top angular speed (rad/s).
BURGER_MAX_ANGULAR = 2.84
