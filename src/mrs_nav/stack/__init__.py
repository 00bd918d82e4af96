"""The whole stack (simulator + SLAM + navigation) headless in one process, as ``mrs-nav demo`` runs it."""
