"""Tree planners with circular-arc edges (assignment 3): arcs, the tree, RRT and RRT*."""
