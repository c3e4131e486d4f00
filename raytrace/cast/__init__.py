"""Casting your own rays: ``RayScene`` and its one-call helpers
(``rayscene``), and the drop-in for trimesh (``trimesh_ray``)."""
