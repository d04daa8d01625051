"""APS_load_param_from_file / APS_save_param_to_file: the board and axis parameters as an XML
file of MotionCreatorPro 2 entries [spec adlink.md §4.1, ASSUMPTION].

MotionCreatorPro's schema is not published; the virtual card reads and writes this layout (card
README "Parameter files"), and applies the entries it understands:

    <MotionCreatorPro>
      <Board ID="0" Name="AMP-208C">
        <Param No="0x0" Name="PRB_EMG_LOGIC" Value="0"/>
        <Axis ID="0">
          <Param No="0x21" Name="PRA_ACC" Value="1000000"/>
        </Axis>
      </Board>
    </MotionCreatorPro>

`No` wins over `Name` when both are given; an axis is the board's local axis. A file larger than
MAX_FILE_BYTES, not XML, or naming an unknown board, axis or parameter is ERR_FILE_FORMAT (-20)
with nothing applied (every entry is checked against the card before any is set).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from typing import Any

from vdevmaps.aps_defs import (
    ERR_FILE_FORMAT,
    PRA_NAMES,
    PRB_NAMES,
    ERR_NoError,
    ERR_ParametersInvalid,
)

from vdevclient._aps_session import ApsArgError, guarded, session
from vdevclient._cargs import text

MAX_FILE_BYTES = 4 << 20
_PRA = {name: no for no, name in PRA_NAMES.items()}
_PRB = {name: no for no, name in PRB_NAMES.items()}
_MODEL = {0x204: "AMP-204C", 0x208: "AMP-208C"}


def _path(param: Any) -> str:
    """The file name argument: a string or char array; NULL (None) or anything else is -10."""
    try:
        path = text(param).decode("latin-1")
    except (TypeError, ValueError):
        raise ApsArgError(ERR_ParametersInvalid) from None
    if not path:
        raise ApsArgError(ERR_ParametersInvalid)
    return path


def _number(entry: ET.Element, names: dict[str, int]) -> int:
    no, name = entry.get("No"), entry.get("Name")
    try:
        if no is not None:
            return int(no, 0)
        if name is not None:
            return names[name]
    except (ValueError, KeyError):
        pass
    raise ApsArgError(ERR_FILE_FORMAT)


def _value(entry: ET.Element) -> float:
    try:
        return float(entry.get("Value", ""))
    except ValueError:
        raise ApsArgError(ERR_FILE_FORMAT) from None


def _entries(path: str) -> list[tuple[Any, int | None, int, float]]:
    """(board, local axis or None, number, value) of every entry, checked before any is set."""
    try:
        if os.path.getsize(path) > MAX_FILE_BYTES:
            raise ApsArgError(ERR_FILE_FORMAT)
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        raise ApsArgError(ERR_FILE_FORMAT) from None
    s = session()
    found: list[tuple[Any, int | None, int, float]] = []
    for b in root.iter("Board"):
        try:
            board = s.boards[int(b.get("ID", ""), 0)]
        except (ValueError, KeyError):
            raise ApsArgError(ERR_FILE_FORMAT) from None
        for p in b.findall("Param"):
            found.append((board, None, _number(p, _PRB), _value(p)))
        for ax in b.findall("Axis"):
            try:
                a = int(ax.get("ID", ""), 0)
            except ValueError:
                raise ApsArgError(ERR_FILE_FORMAT) from None
            if not 0 <= a < board.axes:
                raise ApsArgError(ERR_FILE_FORMAT)
            for p in ax.findall("Param"):
                found.append((board, a, _number(p, _PRA), _value(p)))
    return found


@guarded
def APS_load_param_from_file(pXMLFile: Any) -> int:
    """Apply the file's board and axis parameters (all or none: a value the card refuses is
    its code, after the entries before it were set; the file is checked first)."""
    entries = _entries(_path(pXMLFile))
    for board, a, no, value in entries:
        if a is None:
            if value != int(value):
                return ERR_FILE_FORMAT
            rc = board.post("set_board_param", no, int(value))[0]
        else:
            rc = board.post("set_axis_param_f", a, no, value)[0]
        if rc != ERR_NoError:
            return rc
    return ERR_NoError


@guarded
def APS_save_param_to_file(Board_ID: int, pXMLFile: Any) -> int:
    """Write board `Board_ID`'s parameters to the file (atomically: a temporary file renamed)."""
    from vdevclient._aps_session import board as find_board

    b = find_board(Board_ID)
    path = _path(pXMLFile)
    root = ET.Element("MotionCreatorPro")
    node = ET.SubElement(root, "Board", ID=str(b.board_id), Name=_MODEL.get(b.model, "AMP"))
    rc, (numbers, values) = b.post("get_board_param_table")
    if rc != ERR_NoError:
        return rc
    for no, v in zip(numbers, values, strict=True):
        ET.SubElement(node, "Param", No=hex(no), Name=PRB_NAMES.get(no, ""), Value=_fmt(v))
    for a in range(b.axes):
        rc, (numbers, values) = b.post("get_axis_param_table", a)
        if rc != ERR_NoError:
            return rc
        ax = ET.SubElement(node, "Axis", ID=str(a))
        for no, v in zip(numbers, values, strict=True):
            ET.SubElement(ax, "Param", No=hex(no), Name=PRA_NAMES.get(no, ""), Value=_fmt(v))
    tmp = f"{path}.tmp{os.getpid()}"
    try:
        ET.ElementTree(root).write(tmp, encoding="utf-8", xml_declaration=True)
        os.replace(tmp, path)
    except OSError:
        return ERR_FILE_FORMAT
    return ERR_NoError


def _fmt(v: float) -> str:
    return str(int(v)) if math.isfinite(v) and v == int(v) and abs(v) < 2**53 else repr(v)


__all__ = [n for n in dir() if n.startswith("APS_")]
