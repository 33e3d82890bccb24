"""tactile simulation: object geometry, rolling and sweeping, F/T sensor model, board emulator."""
