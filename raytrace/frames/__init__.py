"""Many images from one scene: camera paths (``animation``), their writers
(GIF, MP4, PNG sequences: ``writers``), tiles and frames as tasks
(``batch``), on Dask (``distributed``)."""
