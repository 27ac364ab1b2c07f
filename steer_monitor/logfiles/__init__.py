"""Log files of the steering bus: readers and writers of candump, ASC, BLF, MCAP and the
gateways' text formats (Actisense, Yacht Devices, canboat), their compressed forms, the
column readers the batch path uses, and the decoding of a whole log with clock steps
stitched.

The boundary where python-can's, mcap's and the decompressors' errors become
:class:`~steer_monitor.errors.SteerMonitorError`. The vessel side (bus, node) never needs
this package but for the recorder's MCAP writer; the core (``model``, ``estimate``) never
imports it.
"""
