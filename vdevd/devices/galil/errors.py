"""TC error codes of the DMC-13X8 (manual ch. 5 "Controller Response to DATA", TC command).

The card answers `?` to a command it cannot accept and remembers the reason; `TC1` tells the code
and its text, `_TC` reads the code. Texts from the Optima-generation TC table (spec galil.md §4.3).
"""

from __future__ import annotations

import enum


class TC(enum.IntEnum):
    """The TC codes this firmware raises (names after the manual's texts)."""

    UNRECOGNIZED_COMMAND = 1
    ONLY_VALID_FROM_PROGRAM = 2
    NOT_VALID_IN_PROGRAM = 3
    OPERAND_ERROR = 4
    INPUT_BUFFER_FULL = 5
    NUMBER_OUT_OF_RANGE = 6
    NOT_VALID_WHILE_RUNNING = 7
    NOT_VALID_WHEN_NOT_RUNNING = 8
    VARIABLE_ERROR = 9
    EMPTY_PROGRAM_LINE = 10
    INVALID_LABEL = 11
    SUBROUTINE_TOO_DEEP = 12
    JG_ONLY_IN_JOG_MODE = 13
    IP_INCORRECT_SIGN = 16
    NOT_VALID_WHILE_PROGRAM_RUNS = 17
    NOT_VALID_CONTOURING = 18
    APPLICATION_STRAND_RUNNING = 19
    BEGIN_WITH_MOTOR_OFF = 20
    BEGIN_WHILE_RUNNING = 21
    BEGIN_LIMIT_SWITCH = 22
    IN_WITHOUT_VARIABLE = 25
    S_OPERAND_NOT_VALID = 28
    NO_TIME_SPECIFIED = 39
    GEAR_MASTER_AND_FOLLOWER = 46
    NOT_ENOUGH_FIELDS = 50
    QUESTION_MARK_NOT_VALID = 51
    MISSING_QUOTE = 52
    MISSING_BRACKET = 55
    ARRAY_INDEX_INVALID = 56
    BAD_FUNCTION = 57
    MISMATCHED_PARENTHESES = 59
    DOWNLOAD_ERROR = 60
    BAD_LABEL = 61
    TOO_MANY_LABELS = 62
    IF_WITHOUT_ENDIF = 63
    IN_ONLY_IN_THREAD_0 = 71
    NOT_A_VALID_NUMBER = 83
    ONLY_ABCD_VALID = 90
    SM_JUMPER_NEEDED = 96
    BAD_BINARY_FORMAT = 97
    BINARY_NOT_IN_PROGRAM = 98
    BAD_BINARY_NUMBER = 99
    NOT_VALID_RUNNING_ECAM = 100
    ECAM_INDEX = 101
    NO_ECAM_MASTER = 102
    ECAM_MODULUS_TOO_LARGE = 103
    NOT_VALID_PERFORMING_ECAM = 104
    EB1_FIRST = 105
    PRIVILEGE_VIOLATION = 106
    NOT_BRUSHLESS = 110


#: code -> text, as `TC1` prints it
TEXTS: dict[int, str] = {
    0: "No error",
    1: "Unrecognized command",
    2: "Command only valid from program",
    3: "Command not valid in program",
    4: "Operand error",
    5: "Input buffer full",
    6: "Number out of range",
    7: "Command not valid while running",
    8: "Command not valid when not running",
    9: "Variable error",
    10: "Empty program line or undefined label",
    11: "Invalid label or line number",
    12: "Subroutine more than 16 deep",
    13: "JG only valid when running in jog mode",
    14: "EEPROM check sum error",
    15: "EEPROM write error",
    16: "IP incorrect sign during position move or IP given during forced deceleration",
    17: "ED, BN and DL not valid while program running",
    18: "Command not valid when contouring",
    19: "Application strand already executing",
    20: "Begin not valid with motor off",
    21: "Begin not valid while running",
    22: "Begin not possible due to limit switch",
    24: "Begin not valid because no sequence defined",
    25: "Variable not given in IN command",
    28: "S operand not valid",
    29: "Not valid during coordinated move",
    30: "Sequence segment too short",
    31: "Total move distance in a sequence > 2 billion",
    32: "More than 511 segments in a sequence",
    33: "VP or CR commands cannot be mixed with LI commands",
    39: "No time specified",
    41: "Contouring record range error",
    42: "Contour data being sent too slowly",
    46: "Gear axis both master and follower",
    50: "Not enough fields",
    51: "Question mark not valid",
    52: "Missing \" or string too long",
    53: "Error in {}",
    54: "Question mark part of string",
    55: "Missing [ or []",
    56: "Array index invalid or out of range",
    57: "Bad function or array",
    58: "Bad command response (i.e. _GNX)",
    59: "Mismatched parentheses",
    60: "Download error - line too long or too many lines",
    61: "Duplicate or bad label",
    62: "Too many labels",
    63: "IF statement without ENDIF",
    65: "IN command must have a comma",
    66: "Array space full",
    67: "Too many arrays or variables",
    71: "IN only valid in task #0",
    80: "Record mode already running",
    81: "No array or source specified",
    82: "Undefined array",
    83: "Not a valid number",
    84: "Too many elements",
    90: "Only A B C D valid operand",
    96: "SM jumper needs to be installed for stepper motor operation",
    97: "Bad binary command format",
    98: "Binary commands not valid in application program",
    99: "Bad binary command number",
    100: "Not valid when running ECAM",
    101: "Improper index into ET (must be 0-256)",
    102: "No master axis defined for ECAM",
    103: "Master axis modulus greater than 256*EP value",
    104: "Not valid when axis performing ECAM",
    105: "EB1 command must be given first",
    106: "Privilege violation",
    110: "Must be made brushless by BA command",
    111: "Must be made brushless by BA command",
    112: "BZ command timeout",
    113: "No movement in BZ command",
    114: "BZ command runaway",
    118: "Controller has GL1600 not GL1800",
}


class GalilError(Exception):
    """A command the card refuses: it answers `?` and TC reports `code`."""

    def __init__(self, code: int, detail: str = "") -> None:
        super().__init__(f"TC {code}: {TEXTS.get(code, 'Error')}" + (f" ({detail})" if detail else ""))
        self.code = int(code)
