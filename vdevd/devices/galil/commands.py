"""The DMC-13X8 command table: every mnemonic the interpreter runs, and those it does not yet.

Plain data (vdevd/devices/commands.py): the mnemonic, the `Interpreter` method that runs it, its
static arguments and the manual section ([M Ch6 ...] is the DMC-13X8 User Manual rev 1.0e, spec
is the digest spec/galil.md). The parameter commands and the reports are one entry each of
`PARAMS` and `REPORT_FORMATS`. A mnemonic of the digest the card does not run is listed in
`not_emulated` with the reason; it answers `?` with the TC code of `NOT_EMULATED_CODES`.
"""

from __future__ import annotations

from vdevd.devices.commands import Command, CommandTable
from vdevd.devices.galil.errors import TC
from vdevd.devices.galil.motion import Mode
from vdevd.devices.galil.numbers import REPORT_FORMATS
from vdevd.devices.galil.params import PARAMS

_MOTION = "M Ch6 §Independent Axis Positioning"
_HOME = "M Ch3 §Home Switch Input"
_LINEAR = "M Ch6 §Linear Interpolation Mode"
_VECTOR = "M Ch6 §Vector Mode: Linear and Circular Interpolation Motion"
_REPORT = "M Ch5 §Summary of Interrogation Commands; spec §4.4"
_IO = "M Ch3 §TTL Inputs / §TTL Outputs"
_IRQ = "M Ch4 §Configuring Interrupts"
_PARAM_SECTIONS = {
    **dict.fromkeys(("KP", "KD", "KI", "IL", "TL", "OF", "PL"), "M13-web p.164; spec §5.1"),
    **dict.fromkeys(("FA", "FV"), "M Ch1; spec §5.2"),
    **dict.fromkeys(("ER", "OE"), "M Ch2 Step 7a; spec §5.5"),
    "KS": "M Ch6 §Stepper Motor Operation; spec §5.6",
    "MT": "M Ch6 §Stepper Motor Operation; spec §5.6",
    "CE": "M Ch6 §Using the CE Command",
    "DV": "M Ch6 §Continuous Dual Loop",
    **dict.fromkeys(("FL", "BL"), "M contents §Programmable Position Limits; spec §4.5"),
    "JG": "M Ch6 §Independent Jogging",
    "IT": "M Ch6 §Motion Smoothing",
}

#: (mnemonics, why the card does not run them, the TC code of their `?`)
_NOT_EMULATED: tuple[tuple[tuple[str, ...], str, int], ...] = (
    (("JP", "JS", "EN", "RE", "RI", "IF", "EL", "HX", "ZS", "IN", "II"),
     "application program flow (M Ch7 is not in the seed): issue 20",
     TC.ONLY_VALID_FROM_PROGRAM),
    (("XQ",), "application programs: nothing can be downloaded yet, issue 20",
     TC.EMPTY_PROGRAM_LINE),
    (("DL", "UL", "LS", "ED"), "program download, upload, listing and editor: issue 20",
     TC.UNRECOGNIZED_COMMAND),
    (("DM", "DA"), "arrays come with application programs: issue 20",
     TC.UNRECOGNIZED_COMMAND),
    (("BN", "BP", "BV"), "burning parameters to flash (spec §1.5): issue 20",
     TC.UNRECOGNIZED_COMMAND),
    (("ES",), "ellipse scale: the seed defers its definition to the command reference (ch. 11), "
     "which it lacks", TC.UNRECOGNIZED_COMMAND),
    (("GA", "GR", "GM"), "electronic gearing: issue 20", TC.UNRECOGNIZED_COMMAND),
    (("EA", "EM", "EP", "ET", "EB", "EG", "EQ", "EC", "EW"), "electronic cam: issue 20",
     TC.UNRECOGNIZED_COMMAND),
    (("CM", "CD", "DT", "WC"), "contour mode: issue 20", TC.UNRECOGNIZED_COMMAND),
    (("AD", "AP", "AR", "AS", "AI", "MF", "MR", "AT", "TW"),
     "trippoints other than AM, MC and WT: issue 20", TC.UNRECOGNIZED_COMMAND),
    (("RA", "RD", "RC"), "record mode (automatic data capture into arrays): issue 20",
     TC.UNRECOGNIZED_COMMAND),
    (("BA", "BM", "BB", "BC", "BI", "BS", "BZ"),
     "sinusoidal commutation (spec §5.8): issue 20", TC.UNRECOGNIZED_COMMAND),
    (("QS", "YA", "YB", "YC", "YR", "YS"), "stepper position maintenance (spec §5.6): issue 20",
     TC.UNRECOGNIZED_COMMAND),
    (("OC",), "output compare: not built yet (no issue schedules it)", TC.UNRECOGNIZED_COMMAND),
    (("CO",), "extended I/O banks: the card has none configured", TC.UNRECOGNIZED_COMMAND),
    (("TR",), "program trace: there are no programs yet", TC.UNRECOGNIZED_COMMAND),
    (("PF", "VF"), "reply formats are fixed at the defaults (PF 10.0, VF 10.4)",
     TC.UNRECOGNIZED_COMMAND),
    (("AF",), "analog feedback: every axis reads its encoder", TC.UNRECOGNIZED_COMMAND),
)

COMMANDS = CommandTable(
    [
        # -- independent motion [M Ch6] ---------------------------------------------------------
        Command("BG", "_bg", section=_MOTION),
        Command("ST", "_st", section=_MOTION),
        Command("AB", "_ab", section="M Ch6 §Specifying Linear Segments"),
        Command("MO", "_mo", section="M Ch2"),
        Command("SH", "_sh", section="M Ch2"),
        Command("HM", "_mode_cmd", (Mode.HM,), section=_HOME),
        Command("FE", "_mode_cmd", (Mode.FE,), section=_HOME),
        Command("FI", "_mode_cmd", (Mode.FI,), section=_HOME),
        Command("DP", "_dp", section="M Ch2 Ex6; M Ch6 §Stepper Motor Operation"),
        Command("DE", "_de", section="M Ch6 §Continuous Dual Loop"),
        Command("IP", "_ip", section=_MOTION),
        # -- coordinated motion [M Ch6 §Linear Interpolation Mode, §Vector Mode] -------------------
        Command("LM", "_lm", section=_LINEAR),
        Command("LI", "_li", section=_LINEAR),
        Command("LE", "_le", section=_LINEAR),
        Command("VM", "_vm", section=_VECTOR),
        Command("VP", "_vp", section=_VECTOR),
        Command("CR", "_cr", section=_VECTOR),
        Command("VE", "_le", section=_VECTOR),
        Command("CS", "_cs", section=_LINEAR),
        Command("CA", "_ca", section="M Ch6 §Specifying the Coordinate Plane"),
        Command("TN", "_tn", section="M Ch6 §Tangent Motion"),
        Command("AV", "_av", section="M Ch6 §Linear Interpolation Mode (#LMOVE)"),
        *(Command(name, "_vector_param", (name,), section=_LINEAR)
          for name in ("VS", "VA", "VD", "VR", "VT")),
        # -- trippoints on the command line [M Ch6; spec §5.7] ----------------------------------
        Command("AM", "_am", section=_MOTION),
        Command("MC", "_mc", section="M Ch6 §Motion Complete Trippoint"),
        Command("WT", "_wt", section="M Ch2 Ex10"),
        Command("AL", "_al", section="M Ch3 Fig 3-1 §High Speed Position Capture"),
        # -- reports and messages ---------------------------------------------------------------
        *(Command(name, "_report", (name,), section=_REPORT) for name in REPORT_FORMATS),
        Command("TC", "_tc", section="M Ch5 §Controller Response; spec §4.3"),
        Command("TB", "_tb", section=_REPORT),
        Command("TI", "_ti", section=_REPORT),
        Command("TZ", "_tz", section="spec §4.5 I/O"),
        Command("MG", "_mg", section="M Ch6 §Messages"),
        Command("QZ", "_qz", section="M Ch4 §DMA / Secondary FIFO Memory Map"),
        Command("\x12\x16", "_version", section="DMCLIB DMCVersion (^R^V)"),
        # -- settings ---------------------------------------------------------------------------
        Command("EO", "_flag", ("echo",), section="M Ch4 §Communication with Controller"),
        Command("LZ", "_flag", ("lz",), section="M Ch5 §Interrogation Commands"),
        Command("TM", "_tm", section="M Ch5 binary command table"),
        Command("DR", "_dr", section="M Ch4 §Secondary FIFO"),
        Command("RS", "_rs", section="M Ch4 §Clearing FIFO Buffer"),
        Command("\x12\x13", "_rs", section="DMCLIB DMCMasterReset (^R^S)"),
        Command("CN", "_cn", section="M Ch3; M Ch5 binary command table"),
        Command("KF", "_ignored", section="M Ch5 binary command table; spec §4.5 (A)"),
        # -- I/O [M Ch3] -------------------------------------------------------------------------
        Command("SB", "_sb", section=_IO),
        Command("CB", "_cb", section=_IO),
        Command("OB", "_ob", section=_IO),
        Command("OP", "_op", section=_IO),
        # -- interrupts [M Ch4] ------------------------------------------------------------------
        Command("EI", "_ei", section=_IRQ),
        Command("UI", "_ui", section="M Ch4 §Setting up Interrupts"),
        # -- parameters [spec §1.3] ----------------------------------------------------------------
        *(Command(name, "_param", (name,), section=_PARAM_SECTIONS.get(name, _MOTION))
          for name in PARAMS),
        # -- statements that are no mnemonic (syntax.split_statement names them) ---------------------
        Command("=", "_assign", section="M Ch2 Ex14 (variables)"),
        Command("#", "_label", section="M Ch2 Ex11 (labels)"),
        Command("'", "_ignored", section="spec §4.1 (comment)"),
        Command("REM", "_ignored", section="spec §4.1 (comment)"),
        Command("", "_ignored", section="spec §4.1 (empty statement)"),
    ],
    not_emulated={name: why for names, why, _ in _NOT_EMULATED for name in names},
)

#: the TC code a command of `COMMANDS.not_emulated` answers `?` with
NOT_EMULATED_CODES: dict[str, int] = {name: code for names, _, code in _NOT_EMULATED for name in names}
