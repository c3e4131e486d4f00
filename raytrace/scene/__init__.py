"""The scene: its description (``model``), loading any kind of scene
(``load``: built-in names, mesh files, scene files), the file formats
(``formats``), the built-in scenes (``builtin``, ``teapot``), framing a bare
mesh, and flattening a scene to the kernels' buffers (``flatten``,
``normals``)."""
