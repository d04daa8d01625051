"""The on-line commands of the Turbo PMAC as plain data [spec pmac.md §2.4, §2.5, §1.7, §1.8].

`COMMANDS` names, for each command, the `Interpreter` method that runs it and the static
arguments it gets first (`RX` is `memory("X", False, line, port, out)`); `kind` says how the
parser finds it: `CHAR` commands start with their one character (`#`, `&`, `?`, `$`, `%`), `WORD`
commands are the longest word a run of letters starts with (after the variables `I`, `P`, `Q`,
`M` with a number, which come first). The interpreter binds the table once (`COMMANDS.bind`).

`COMMANDS.not_emulated` lists the on-line commands the digest documents that the card does not run
yet, with the reason; `REFUSED` is the error number those the parser recognises answer (the others
are unrecognised: ERR003). Data gathering: gather.py, PLCs: plc.py, motion programs: programs.py
and program_runner.py (README "Not yet").
"""

from __future__ import annotations

from vdevd.devices.commands import Command, CommandTable
from vdevd.devices.pmac.errors import ERR_NOT_OPEN

CHAR, WORD = "char", "word"
#: the variable letters: followed by a number or `(`, a variable, not a word [§2.5]
VARIABLES = "IPQM"
#: words answered by the card's identity [DLS-lib, EPICS-HW; digest §2.4]
IDENTITY = ("VERSION", "VER", "CID", "CPU", "TYPE", "DATE", "VID")

_S24, _S25, _S17, _S18 = "§2.4", "§2.5", "§1.7 [A L3118-3219]", "§1.8"


def _word(name: str, handler: str, *args: object, section: str = _S25) -> Command:
    return Command(name, handler, args, WORD, section)


def _char(name: str, handler: str, section: str = _S25) -> Command:
    return Command(name, handler, (), CHAR, section)


COMMANDS = CommandTable(
    [
        # addressing, status, reset, feed rate: dispatched on their first character
        _char("#", "address_motor"),          # #n, #, ##n, #n-> [§2.4 "Ports", SRM p.270]
        _char("&", "address_cs"),             # &n, &
        _char("?", "status"),                 # ? ?? ??? [§2.6]
        _char("$", "dollar"),                 # $ $* $$ $$* $$$ $$$***
        _char("%", "feed"),                   # % %{v}
        _char("^", "trigger_alone"),          # {jog}^{c}: J's (online.jog); alone ERR003
        _char("/", "stop_at_move_end", section="§2.8"),   # stop_commands.py [SRM /]
        _char("\\", "quick_stop", section="§2.8"),       # stop_commands.py [SRM \]
        _char("!", "altered_destination", section="§1.8 [A L3232]"),  # !{axis}{data} altdest.py
        # identity [§2.4 "Number formatting"]
        *(_word(name, "identity", name, section=_S24) for name in IDENTITY),
        # motor commands and reports [§2.5, §2.7]
        _word("J", "jog"),
        _word("HOME", "home", False), _word("HM", "home", False),
        _word("HOMEZ", "home", True), _word("HMZ", "home", True),
        _word("K", "kill"),
        _word("O", "open_loop"),
        _word("P", "report", "P"), _word("V", "report", "V"), _word("F", "report", "F"),
        # coordinate system [§2.5, §2.8]
        _word("A", "abort"),
        _word("H", "hold"),
        # motion-program run control [§2.5, §2.8; program_runner.py]
        _word("B", "begin", section="§2.8"),
        _word("R", "run", False, section="§2.8"),
        _word("S", "run", True, section="§2.8"),
        _word("Q", "quit", section="§2.8"),
        _word("ABR", "abort_run", section="§2.8 [A L3261]"),
        _word("PC", "program_report", "PC", section="§2.8"),
        _word("PE", "program_report", "PE", section="§2.8"),
        _word("PMATCH", "pmatch", section="§2.8 [SRM OPEN FORWARD, PMATCH]"),
        _word("UNDEFINE", "undefine", section=f"{_S25} [A L3284]"),
        _word("UNDEF", "undefine", section=f"{_S25} [A L3284]"),
        # global
        _word("SAVE", "save"),
        _word("PASSWORD", "passthrough", section=_S24),
        _word("LOCK", "lock", False, section=f"{_S18} [A L3264]"),
        _word("UNLOCK", "lock", True, section=f"{_S18} [A L3264]"),
        _word("MOVETIME", "movetime", section=f"{_S18} [A L3262]"),
        _word("SETPHASE", "setphase", section=f"{_S18} [A L3263]"),
        _word("MS", "macro_station", section="Turbo SRM MS/MSR/MSW; §3.3"),
        _word("PR", "program_remaining", section="Turbo SRM PR, I16/I17; rotary.py"),
        # tables [§1.7]
        _word("DEFINE", "define", section=_S17), _word("DEF", "define", section=_S17),
        _word("DELETE", "delete", section=_S17), _word("DEL", "delete", section=_S17),
        _word("LIST", "list_table", section=_S17),
        # data gathering [§2.2 I5000-I5051, §3.3; gather.py]
        _word("GATHER", "gather"), _word("GAT", "gather"),
        _word("ENDGATHER", "end_gather", False), _word("ENDGAT", "end_gather", False),
        _word("ENDG", "end_gather", False), _word("END", "end_gather", True),
        # PLC buffers and run control [§2.9; plc.py]
        _word("OPEN", "open_buffer", section="§2.9"),
        _word("CLOSE", "close_nothing", section="§2.9"),
        _word("ENABLE", "plc_control", True, section="§2.9"),
        _word("ENA", "plc_control", True, section="§2.9"),
        _word("DISABLE", "plc_control", False, section="§2.9"),
        _word("DIS", "plc_control", False, section="§2.9"),
        _word("PAUSE", "plc_pause", False, section="§2.9; Turbo SRM PAUSE PLC"),
        _word("RESUME", "plc_pause", True, section="§2.9; Turbo SRM RESUME PLC"),
        # memory words [§2.5, §2.1]
        *(_word(f"{rw}{space}", "memory", space, rw == "W")
          for rw in "RW" for space in "XYLD"),
    ],
    not_emulated={
        "CLEAR": "only the port with a buffer open may CLEAR it (plc.py)",
        "LEARN": "on-line (no buffer open on the port) ERR005; into an open buffer: learn.py",
    },
)

#: not emulated words the parser recognises -> the error number they answer (README "Not yet")
REFUSED: dict[str, int] = {
    "CLEAR": ERR_NOT_OPEN, "LEARN": ERR_NOT_OPEN,
}
