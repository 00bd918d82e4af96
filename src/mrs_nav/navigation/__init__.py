"""Navigating to a goal on a live map (assignment 4).

Goal state machine, replanning policy, planning off the control loop.
"""
