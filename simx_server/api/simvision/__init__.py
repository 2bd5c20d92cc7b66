"""CoppeliaSim's ``simVision`` (its vision plug-in, CoppeliaRobotics/simVision
``sourceCode/simVision.cpp``) for child scripts (``simVision = require('simVision')``, or the
global) and ZMQ clients (``client.require('simVision')``).

Each function works on a vision sensor's *work image* and its two buffers (float RGB in 0..1,
kept per sensor: :class:`simx_server.sim.vision_filters.FilterState`), with the same code that
applies a sensor's ``filters=`` chain (:mod:`simx_server.sim.vision_filters`,
:mod:`simx_server.sim.vision_blobs`, :mod:`simx_server.sim.vision_points`). A sensor's vision
callback (``sysCall_vision``, :mod:`simx_server.scripts.vision_callbacks`) typically reads the
sensor's image into the work image (``sensorImgToWorkImg``), processes it, measures it
(``blobDetectionOnWorkImg`` returns a packed packet the callback returns in ``packedPackets``)
and writes it back (``workImgToSensorImg``): the image clients then read. Called outside a
callback, the input functions read what the sensor shows now and the output functions write
what it shows until the world changes.

As the plug-in: the handle may be ``sim.handle_self`` (the script's object); a function other
than the input ones before any input answers "work image not initialized";
``workImgToSensorImg(h)`` drops the work image when no buffer was used (``removeBuffer`` false
keeps it); functions without results return ``false`` (the plug-in's); measuring functions
return ``trigger, packedPacket`` (float32 values packed as ``sim.packFloatTable`` does).

Not here (each is an error naming it): ``distort``, ``handleSpherical``,
``handleAnaglyphStereo``, the Velodyne rigs (``createVelodyneHDL64E`` ... ``handleVelodyneVPL16``;
``velodyneDataFromWorkImg`` is).
"""

from __future__ import annotations

from simx_server.api.simvision import filters, measure, work  # noqa: F401 (each module registers its functions)
