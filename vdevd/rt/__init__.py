"""The real-time part: the scheduler and the numpy motion core (DESIGN.md)."""

from vdevd.rt.axes import Axes, AxisFlag, PlantKind, ProfileMode, wrap_int32
from vdevd.rt.core import MotionCore
from vdevd.rt.filters import Pid
from vdevd.rt.limits import Limits
from vdevd.rt.plants import ServoPlant, StepperPlant, default_gains
from vdevd.rt.profiles import ProfileGenerator

__all__ = ["AxisFlag", "Axes", "Limits", "MotionCore", "Pid", "PlantKind", "ProfileGenerator",
           "ProfileMode", "ServoPlant", "StepperPlant", "default_gains", "wrap_int32"]
