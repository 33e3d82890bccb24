"""The board as the host meets it: the serial link, the stream and its messages, the client.

- ``serial_port``: open a port (a device path, or a ``sim://`` URL the application
  registers), with one-line errors;
- ``stream_decoder``: COBS frames to protocol messages, counting loss;
- ``client``: the handshake and the commands (CONFIG, TARE, START, SET_CAL ...);
- ``flashing``, ``raw_repl``, ``handover``: putting the firmware on a MicroPython board
  and checking that it answers;

The board's settings in SI units are ``tactile_protocol.settings``, one vocabulary for the
CLI, the firmware and the emulator.
"""
