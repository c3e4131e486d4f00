"""The ``raytrace`` command: the entry point (``command``), the click
group and render command (``main``), ``raytrace compare`` and its figure."""
