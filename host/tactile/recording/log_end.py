"""When a recording with a pose log stops: once the log's end has passed on the log's clock.

``until`` is (clock, end in us, how it was found): the clock is the board's (its latest stamp
heard, or between frames the board -> host fit at the host's time) or one of the host's
(monotonic, UTC), as ``tactile.logs.tags`` names them.
"""

from tactile.logs.tags import show_time


class LogEnd:
    """The pose log's end for a session: ``passed()``, ``left_s()``, in words, in meta.json."""

    def __init__(self, until, timing, clock, utc):
        self.clock_name, self.end_us, self.how = until
        self.timing, self.clock, self.utc = timing, clock, utc

    def now_us(self):
        """Now on the log's clock (us): the board's latest stamp heard (-1: none yet), or a
        host clock's reading."""
        if self.clock_name == "board":
            now = self.timing.board_us()
            return -1 if now is None else now
        return round((self.clock() if self.clock_name == "monotonic" else self.utc()) * 1e6)

    def passed(self):
        return self.now_us() >= self.end_us

    def left_s(self):
        """Seconds until the log's end; None before any board time (a board-clock log)."""
        now = self.now_us()
        segments = self.timing.board.segments
        seg = segments[-1] if segments else None
        if self.clock_name == "board" and seg is not None and seg.usable():  # between frames
            now = max(now, round(float(seg.fitted.to_board(self.clock())) * 1e6))
        return None if now < 0 else max(0.0, (self.end_us - now) / 1e6)

    def words(self):
        when = show_time(self.clock_name, self.end_us)
        left = self.left_s()
        if left is None:
            return f"pose log end ({when}); no board time heard yet"
        return f"pose log end in {left:.1f} s ({when})"

    def meta(self):
        how = f"the pose log: {self.how}"
        return {"clock": self.clock_name, "time_us": self.end_us, "from": how}
