"""Driving a differential-drive robot (assignment 1.2, 4c): feedback linearisation and path following."""
