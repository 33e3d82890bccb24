"""Hold a scene until a host opens the port, as a robot waits for its operator.

A scene's motion starts at simulated time 0; served on a pty before anyone
listens, its first contacts would go to nobody.  ``serve_when_opened`` waits
for a host to open the pty, then serves (the firmware boots with the port,
as a USB-powered board does).
"""


def wait_for_host(server, poll_s=0.01):
    """Block until a host has the pty open or ``server.stop`` is set; True if opened."""
    endpoint = server.endpoint
    while not server.stop:
        if endpoint.wait(poll_s)[1]:
            return True
    return False


def serve_when_opened(server, duration_s=None):
    """``server.serve(duration_s)`` once a host has opened the port."""
    if server.endpoint is None:
        server.open()
    if wait_for_host(server):
        server.serve(duration_s)
