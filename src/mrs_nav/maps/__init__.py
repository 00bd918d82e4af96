"""Maps and worlds: occupancy grids, map_server files, Gazebo world files, planar obstacles and rasterising."""
