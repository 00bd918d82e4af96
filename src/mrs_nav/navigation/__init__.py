"""Navigating to a goal on a live map (assignment 4).

``navigator`` (the :class:`~mrs_nav.navigation.navigator.Navigator` composing the parts; its public names are
importable from there), ``goal`` (the goal state machine), ``replanning`` (when to plan and which plan to take),
``plan_worker`` (planning off the control loop, the planners), ``obstacles`` (laser returns the map lacks) and
``config``.
"""
