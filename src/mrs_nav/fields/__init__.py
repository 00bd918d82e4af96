"""The potential-field method (assignment 1.1).

Fields, randomised escape, simplification, shortest path, the follower.
"""
