"""The commands beside the sort: calibration, the URDF, the 3-D preview, measurements.

One module per command, each with a ``main(argv) -> int`` that :mod:`mearm.__main__`
dispatches to (``mearm urdf`` is :mod:`mearm.tools.dh_to_urdf`) and that the checkout's
``tools/<module>.py`` scripts call, so both spellings take the same arguments. They ship
in the wheel; the data they read by default (the reference configs) is :mod:`mearm.data`.
"""

__all__: list[str] = []
