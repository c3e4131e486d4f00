"""Reading files: meshes (through trimesh) and TOML scene files.

Every problem with a file is reported as one RaytraceError that names it.
"""
