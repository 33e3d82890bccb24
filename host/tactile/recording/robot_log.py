"""The robot logs' format, where the recording's readers found it: ``tactile.logs.robot_log``."""

from tactile.logs.robot_log import *  # noqa: F403
from tactile.logs.robot_log import __all__  # noqa: F401
