"""pyserial URL handlers provided by the simulator (``sim://SCENE``).

Register with ``tactile_sim.urlhandler.register()``, which appends this
package to ``serial.protocol_handler_packages``; the host does that itself
when it is given a ``sim://`` port.
"""


def register():
    import serial

    if __name__ not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(__name__)
