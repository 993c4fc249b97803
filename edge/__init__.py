"""mast-stereo: the shore-mast stereo ship-ranging appliance.

`edge.core` is pure computation; the rest of `edge` composes it with the
hardware drivers in `drivers` (which never import `edge`).
"""

__version__ = "0.1.0"
