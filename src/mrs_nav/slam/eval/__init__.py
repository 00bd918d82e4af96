"""How good a SLAM run is, apart from the algorithm: trajectory errors against a reference (:mod:`.metrics`),
the relations metric of Kummerle et al. 2009 (:mod:`.relations`), map consistency without ground truth
(:mod:`.consistency`), map IoU against a known world (:mod:`.map_iou`) and scripted drives through the simulator
(:mod:`.sim_drive`). Used by ``mrs-nav replay``, the benchmarks and the tests; the SLAM itself never imports it.
"""
