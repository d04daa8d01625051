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
_GEAR = "M Ch6 §Electronic Gearing"
_ECAM = "M Ch6 §Electronic Cam"
_CONTOUR = "M Ch6 §Contour Mode"
_SPM = "M Ch6 §Stepper Position Maintenance Mode; spec §5.6"
_BLM = "M Ch2 Step 5, Step 7b; spec §5.8"
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
    (("ED",), "the on-board editor needs an operator terminal (use DL, UL, LS)",
     TC.UNRECOGNIZED_COMMAND),
    (("EW",), "ECAM widen segment: defined only in Application Note #2444, not in the manual",
     TC.UNRECOGNIZED_COMMAND),
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
        Command("ES", "_es", section="M Ch6 §Compensating for Differences in Encoder Resolution"),
        Command("AV", "_av", section="M Ch6 §Linear Interpolation Mode (#LMOVE)"),
        *(Command(name, "_vector_param", (name,), section=_LINEAR)
          for name in ("VS", "VA", "VD", "VR", "VT")),
        # -- trippoints on the command line [M Ch6; spec §5.7] ----------------------------------
        Command("AM", "_am", section=_MOTION),
        Command("MC", "_mc", section="M Ch6 §Motion Complete Trippoint"),
        Command("WT", "_wt", section="M Ch2 Ex10"),
        Command("AL", "_al", section="M Ch3 Fig 3-1 §High Speed Position Capture"),
        # -- application programs (program_commands.py, threads.py) [spec §4.5] ------------------
        Command("AD", "_ad", section="M Ch2 Ex13"),
        Command("AP", "_ap", section="M Ch2 Ex13"),
        Command("AR", "_ar", section="spec §5.7"),
        Command("AS", "_as", section="M Ch6 §Operand Summary; spec §5.7"),
        Command("AI", "_ai", section="M Ch6 §Electronic Cam"),
        Command("AT", "_at", section="spec §5.7; the Galil command reference (AT)"),
        Command("MF", "_mf", section="M Ch6 §Electronic Cam"),
        Command("MR", "_mr", section="spec §5.7"),
        Command("TW", "_tw", section="spec §4.4 (SC 99 MC timeout)"),
        Command("DL", "_dl", section="DMCLIB DMCDownloadFile; spec §4.5"),
        Command("UL", "_ul", section="DMCLIB DMCUploadFile; spec §4.5"),
        Command("LS", "_ls", section="M Ch2 Ex11; spec §4.5"),
        Command("XQ", "_xq", section="M Ch2 Ex11"),
        Command("HX", "_hx", section="spec §4.5"),
        Command("II", "_ii", section="1400-CR 113; spec §4.5"),
        Command("TR", "_tr", section="M Ch5 §Summary of Interrogation Commands"),
        Command("PW", "_pw", section="Galil command reference (PW); README"),
        Command("\x0c\x0b", "_lock", section="Galil command reference (^L^K); README"),
        Command("CW", "_cw", section="spec §2.4 (unsolicited output); README"),
        *(Command(name, "_program_only", section="spec §4.5 (program flow)")
          for name in ("JP", "JS", "EN", "RE", "RI", "IF", "EL", "ZS", "IN")),
        Command("BP", "_burn", ("programs",), section="spec §1.5"),
        Command("BV", "_burn", ("variables",), section="spec §1.5"),
        Command("BN", "_burn", ("parameters",), section="M Ch2 Step 7b E; spec §1.5"),
        Command("NO", "_ignored", section="spec §4.1 (no operation / comment)"),
        # -- electronic gearing, ECAM, contour [M Ch6] (follow_commands.py) -----------------------
        Command("GA", "ga", section=_GEAR),
        Command("GR", "gr", section=_GEAR),
        Command("GM", "gm", section=_GEAR),
        *(Command(name, name.lower(), section=_ECAM)
          for name in ("EA", "EM", "EP", "ET", "EB", "EG", "EQ", "EC")),
        *(Command(name, name.lower(), section=_CONTOUR) for name in ("CM", "CD", "DT", "WC")),
        # -- stepper position maintenance [M Ch6 §SPM] ---------------------------------------------
        *(Command(name, "spm_param", (name,), section=_SPM) for name in ("YA", "YB", "YC")),
        *(Command(name, name.lower(), section=_SPM) for name in ("YS", "YR", "QS")),
        # -- sinusoidal commutation [M Ch2 Step 5, 7b; spec §5.8] -----------------------------------
        *(Command(name, "b_param", (name,), section=_BLM) for name in ("BM", "BI", "BB")),
        *(Command(name, name.lower(), section=_BLM) for name in ("BA", "BC", "BZ", "BS")),
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
        Command("PF", "pf", section="M Ch5 §Interrogation Commands; spec §4.4 (formats.py)"),
        Command("VF", "vf", section="M Ch5 §Interrogation Commands; spec §4.4 (formats.py)"),
        Command("TM", "_tm", section="M Ch5 binary command table"),
        Command("DR", "_dr", section="M Ch4 §Secondary FIFO"),
        Command("RS", "_rs", section="M Ch4 §Clearing FIFO Buffer"),
        Command("\x12\x13", "_master_reset", section="DMCLIB DMCMasterReset (^R^S); M Ch2 §Master Reset"),
        Command("CN", "_cn", section="M Ch3; M Ch5 binary command table"),
        Command("KF", "_ignored", section="M Ch5 binary command table; spec §4.5 (A)"),
        # -- I/O [M Ch3] -------------------------------------------------------------------------
        Command("SB", "_sb", section=_IO),
        Command("CB", "_cb", section=_IO),
        Command("OB", "_ob", section=_IO),
        Command("OP", "_op", section=_IO),
        Command("AF", "af", section="M Ch1 §Encoder (analog feedback)"),
        Command("OC", "oc", section="M Ch3 §TTL Outputs (output compare)"),
        Command("CO", "co", section="M Ch1 §General I/O; M Ch3 §Uncommitted Digital Inputs"),
        # -- interrupts [M Ch4] ------------------------------------------------------------------
        Command("EI", "_ei", section=_IRQ),
        Command("UI", "_ui", section="M Ch4 §Setting up Interrupts"),
        # -- parameters [spec §1.3] ----------------------------------------------------------------
        *(Command(name, "_param", (name,), section=_PARAM_SECTIONS.get(name, _MOTION))
          for name in PARAMS),
        # -- arrays, variables and record mode (array_commands.py) --------------------------------
        Command("DM", "_dm", section="M Ch6 §Multiple Moves; spec §4.5 Arrays"),
        Command("DA", "_da", section="spec §4.5 Arrays (A)"),
        Command("LA", "_la", section="spec §4.5 Arrays; gclib GArrayUploadFile"),
        Command("LV", "_lv", section="spec §4.5 Variables"),
        Command("QU", "_qu", section="spec §6.2 DMCArrayUpload"),
        Command("QD", "_qd", section="spec §6.2 DMCArrayDownload"),
        Command("RA", "_ra", section="M Ch6 §Teach"),
        Command("RD", "_rd", section="M Ch6 §Teach"),
        Command("RC", "_rc", section="M Ch6 §Teach"),
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
