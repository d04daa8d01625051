"""Virtual MACRO stations: node MI-variables (`MS{node},MI{n}`, `MS{node},MI{n}={v}`) and node
registers (`MSR`, `MSW`) for the nodes the card is configured with (`macro_stations`) [Turbo SRM
"MS", "MSR", "MSW"; spec pmac.md §1.1 (MI9xx node variables), §2.2 (I20-I23), §3.3 item 5
(dls-pmaclib's `ms{node},i{var}`)].

A node number is 0-63: MACRO IC k = node // 16 (I20-I23 hold the ICs' base addresses [A L3225-3229]),
node node % 16 on its ring. A configured node answers as a station would; any other node answers
ERR008, the MACRO auxiliary communications error (no station replies on the ring). Each node keeps
its own MI-variables, 0 at start (ASSUMPTION: the station's own factory values are not in the
sources), integers within the 24-bit range, and a bounded register space (`MSR`/`MSW`). Stations
are hardware of their own: the card's `$$$`, `$$$***` and SAVE leave them as they are.
No I/O; the on-line interpreter parses the command and calls these.
"""

from __future__ import annotations

from collections.abc import Iterable

from vdevd.devices.pmac.errors import ERR_DATA, ERR_MACRO, CommandError

NODES = 64                        # MACRO ICs 0-3 x 16 nodes [Turbo SRM MS]
MI_COUNT = 1024                   # MI0-MI1023 (ASSUMPTION: the station's MI range)
REGISTERS = 0x10000               # station addresses $0000-$FFFF (ASSUMPTION)
LO, HI = -(1 << 23), (1 << 24) - 1  # a 24-bit word, signed or unsigned
#: MACRO IC 0-3 base addresses: what I20-I23 hold when the IC is present [digest §2.1, A L3228]
IC_BASE = (0x078400, 0x079400, 0x07A400, 0x07B400)


class MacroStations:
    """The configured nodes, their MI-variables and registers."""

    def __init__(self, nodes: Iterable[int] = ()) -> None:
        self.mi: dict[int, dict[int, int]] = {}
        self.registers: dict[int, dict[int, int]] = {}
        self.configure(nodes)

    def configure(self, nodes: Iterable[int]) -> None:
        nodes = sorted(set(nodes))
        if any(not 0 <= n < NODES for n in nodes):
            raise ValueError(f"MACRO nodes are 0-{NODES - 1}")
        self.mi = {n: {} for n in nodes}
        self.registers = {n: {} for n in nodes}

    @property
    def nodes(self) -> list[int]:
        return sorted(self.mi)

    def ic_bases(self) -> list[int]:
        """I20-I23: the base of each MACRO IC a configured node is on, 0 for the others."""
        on = {n // 16 for n in self.mi}
        return [IC_BASE[ic] if ic in on else 0 for ic in range(4)]

    def _node(self, node: int) -> None:
        if not 0 <= node < NODES:
            raise CommandError(ERR_DATA, f"MACRO nodes are 0-{NODES - 1}")
        if node not in self.mi:
            raise CommandError(ERR_MACRO, f"no MACRO station answers at node {node}")

    def read_mi(self, node: int, n: int) -> int:
        self._node(node)
        if not 0 <= n < MI_COUNT:
            raise CommandError(ERR_DATA, f"MI{n} does not exist")
        return self.mi[node].get(n, 0)

    def write_mi(self, node: int, n: int, value: float) -> None:
        self._node(node)
        if not 0 <= n < MI_COUNT:
            raise CommandError(ERR_DATA, f"MI{n} does not exist")
        v = round(value)
        if not LO <= v <= HI:
            raise CommandError(ERR_DATA, f"MI{n}={value} outside a 24-bit word")
        if v:
            self.mi[node][n] = v
        else:
            self.mi[node].pop(n, None)

    def read_register(self, node: int, address: int) -> int:
        """MSR: the station word at `address` (0 where never written)."""
        self._node(node)
        if not 0 <= address < REGISTERS:
            raise CommandError(ERR_DATA, f"station address {address:#x} out of range")
        return self.registers[node].get(address, 0)

    def write_register(self, node: int, address: int, value: float) -> None:
        """MSW: the station word at `address`, 24 bits (wrapped as a 24-bit register stores)."""
        self._node(node)
        if not 0 <= address < REGISTERS:
            raise CommandError(ERR_DATA, f"station address {address:#x} out of range")
        v = round(value) & 0xFFFFFF
        if v:
            self.registers[node][address] = v
        else:
            self.registers[node].pop(address, None)
