"""The ADLINK APS library (APS168) for the virtual AMP-204C/208C cards of a vdevd rack: the
functions of the DLL with its names, C argument order and return codes, its constants and its
type_def.h structures [spec adlink.md §4].

An application that calls APS168 through ctypes runs against the virtual cards when it imports
this module instead: pointer parameters take what it passes to the DLL (`byref(c_int32())`,
`pointer(...)`, ctypes arrays, a one-element list) and a C NULL is None; functions return the
APS code (`ERR_NoError` = 0, negative codes of ErrorCodesDef.h), the status functions the word.
`APS_initial` finds the rack's `adlink-amp20xc` cards at $VDEVD_ENDPOINT.
"""

from __future__ import annotations

from vdevmaps.aps_defs import *  # noqa: F403  (ADLINK's constants under their own names)

from vdevclient._aps_dio import *  # noqa: F403
from vdevclient._aps_gear import *  # noqa: F403
from vdevclient._aps_int import *  # noqa: F403
from vdevclient._aps_interp import *  # noqa: F403
from vdevclient._aps_motion import *  # noqa: F403
from vdevclient._aps_params_file import *  # noqa: F403
from vdevclient._aps_ptable import *  # noqa: F403
from vdevclient._aps_pwm import *  # noqa: F403
from vdevclient._aps_sampling import *  # noqa: F403
from vdevclient._aps_system import *  # noqa: F403
from vdevclient._aps_trigger import *  # noqa: F403
from vdevclient._aps_types import *  # noqa: F403
from vdevclient._aps_wdt import *  # noqa: F403
