"""The render: options -> buffers -> structure -> kernel -> image and statistics
(``driver``), and what a render writes (``output``, ``aov``, ``heatmap``,
``overlay``)."""
