"""The ADLINK APS constants (vdevmaps.aps_defs) and structures (vdevclient._aps_types).

Three kinds of checks: explicit values of the key constants (always run); the tables of the digest
`spec/adlink.md` parsed where their layout is regular (skipped when the digest is not beside the
checkout); the structure layouts, derived by hand from natural alignment (MSVC default packing, F64
at 8) and pinned as explicit sizes and offsets.
"""

from __future__ import annotations

import ctypes
import re
import subprocess
import sys
from collections import defaultdict

import pytest
from vdevclient import _aps_types as T
from vdevmaps import aps_defs as A

from tests.devices.digest import digest_text

# ------------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------------


def _consts(prefix: str | tuple[str, ...]) -> dict[str, int]:
    return {
        name: value
        for name, value in vars(A).items()
        if name.startswith(prefix) and isinstance(value, int) and not isinstance(value, bool)
    }


def _by_value(prefix: str | tuple[str, ...], exclude: frozenset[str] = frozenset()) -> dict[int, set[str]]:
    groups: dict[int, set[str]] = defaultdict(set)
    for name, value in _consts(prefix).items():
        if name not in exclude:
            groups[value].add(name)
    return groups


def _section(text: str, heading: str) -> str:
    start = text.index(heading)
    end = text.find("\n### ", start + len(heading))
    return text[start : end if end >= 0 else len(text)]


def _table_rows(section: str) -> list[list[str]]:
    """The cells of every table row of a section (header and separator rows included)."""
    return [
        [cell.strip() for cell in line.strip().strip("|").split("|")]
        for line in section.splitlines()
        if line.lstrip().startswith("|")
    ]


BACKTICKED = re.compile(r"`([A-Z][A-Za-z0-9_]+)`")  # `TGR_TRGx_PWD`: x = channel


@pytest.fixture(scope="module")
def spec() -> str:
    return digest_text("adlink")


# ------------------------------------------------------------------------------------------------------
# explicit values (the brief's and the spec's key numbers)
# ------------------------------------------------------------------------------------------------------


def test_return_codes() -> None:
    assert A.ERR_NoError == 0
    assert A.ERR_DeviceNotInitial == -4
    assert A.ERR_DeviceAlreadyInitialed == -7
    assert A.ERR_InterruptNotEnable == -8
    assert A.ERR_TimeOut == -9
    assert A.ERR_ParametersInvalid == -10
    assert A.ERR_FunctionNotAvailable == -13
    assert A.ERR_CommandInProcess == -15
    assert A.ERR_DistantNotEnough == -22
    assert A.ERR_Read_ModuleType_Dismatch == -34
    assert A.ERR_Win32Error == -1000
    assert A.ERR_DspStart == -2000
    assert A.ERR_NAMES[-15] == "ERR_CommandInProcess"
    # -1 ... -34 without a gap
    assert set(range(-34, 1)) <= set(A.ERR_NAMES)


def test_axis_parameters() -> None:
    assert A.PRA_EL_LOGIC == 0x00
    assert A.PRA_SD_DEC == A.PRA_STP_DEC == 0x07
    assert A.PRA_ZSP_LOGIC == A.PRA_INP_LOGIC == 0x05
    assert A.PRA_HOME_CURVE == A.PRA_HOME_S == 0x12
    assert A.PRA_HOME_SHIFT == 0x17 == 23
    assert A.PRA_HOME_POS == 0x1B
    assert A.PRA_SF == A.PRA_CURVE == 0x20
    assert (A.PRA_ACC, A.PRA_DEC, A.PRA_VS, A.PRA_VM, A.PRA_VE) == (0x21, 0x22, 0x23, 0x24, 0x25)
    assert A.PRA_JG_SF == A.PRA_JG_CURVE == 0x42
    assert A.PRA_JG_OFFSET == A.PRA_JG_STEP == 0x46
    assert A.PRA_JG_MAP_DI_EN == 0x48
    assert A.PRA_JG_JOG_DI == 0x4B
    assert A.PRA_GEAR_MASTER == 0x60
    assert A.PRA_GANTRY_PROTECT_2 == 0x64
    assert A.PRA_ENCODER_MODE == A.PRA_PLS_IPT_MODE == 0x80
    assert A.PRA_PULSE_OUT_MODE == A.PRA_PLS_OPT_MODE == 0x81
    assert A.PRA_POS_UNIT_FACTOR == 0x86 == 134
    assert A.PRA_ERR_POS_LEVEL == A.PRA_ERR_C_LEVEL == 0x124 == 292


def test_pra_names_are_the_primary_names() -> None:
    assert A.PRA_NAMES[0x20] == "PRA_SF"
    assert A.PRA_NAMES[0x07] == "PRA_SD_DEC"
    assert A.PRA_NAMES[0x46] == "PRA_JG_OFFSET"
    assert A.PRA_NAMES[0x124] == "PRA_ERR_POS_LEVEL"
    assert A.PRA_NAMES[0x80] == "PRA_ENCODER_MODE"
    # every number of a PRA_ constant has a name, and the name resolves to the number
    assert set(A.PRA_NAMES) == set(_consts("PRA_").values())
    for number, name in A.PRA_NAMES.items():
        assert getattr(A, name) == number
    assert set(A.PRA_NAMES) >= A.PRA_AMP_USED
    assert 0x90 not in A.PRA_AMP_USED and 0x124 in A.PRA_AMP_USED


def test_board_parameters() -> None:
    assert A.PRB_EMG_LOGIC == A.PRS_EMG_LOGIC == 0
    assert A.PRB_WDT0_VALUE == A.PRB_WDT0_LIMIT == 0x10
    assert (A.PRB_DO_LOGIC, A.PRB_DI_LOGIC) == (0x14, 0x15)
    assert [A.PRB_PWM0_MAP_DO, A.PRB_PWM1_MAP_DO, A.PRB_PWM2_MAP_DO, A.PRB_PWM3_MAP_DO] == [
        0x110,
        0x111,
        0x112,
        0x113,
    ]
    assert A.PRB_NAMES[0] == "PRB_EMG_LOGIC"
    assert A.PRB_NAMES[0x10] == "PRB_WDT0_VALUE"


def test_status_and_io_bits() -> None:
    assert A.MTS_CSTP == 0
    assert A.MTS_MDN == A.MTS_NSTP == 5
    assert A.MTS_HMV == 6
    assert A.MTS_WAIT == 10 and A.MTS_PTB == 11 and A.MTS_JOG == 15
    assert A.MTS_ASTP == 16 and A.MTS_BLD == 17 and A.MTS_PRED == 18 and A.MTS_POSTD == 19
    assert A.MTS_GER == 28
    assert A.MTS_ASTP_V == 0x10000 and A.MTS_MDN_V == 0x20
    assert (A.MIO_ALM, A.MIO_PEL, A.MIO_MEL, A.MIO_ORG) == (0, 1, 2, 3)
    assert (A.MIO_EMG, A.MIO_EZ, A.MIO_INP, A.MIO_SVON) == (4, 5, 6, 7)
    assert (A.MIO_RDY, A.MIO_WARN, A.MIO_ZSP, A.MIO_SPEL, A.MIO_SMEL) == (8, 9, 10, 11, 12)
    assert (A.MIO_TLC, A.MIO_ABSL, A.MIO_STA, A.MIO_PSD, A.MIO_MSD) == (13, 14, 15, 16, 17)
    for name, bit in _consts(("MIO_", "MTS_")).items():
        if not name.endswith("_V") and f"{name}_V" in vars(A):
            assert getattr(A, f"{name}_V") == 1 << bit, name


def test_options() -> None:
    assert (A.OPT_ABSOLUTE, A.OPT_RELATIVE, A.OPT_WAIT, A.OPT_FORCE_ABORT) == (0, 1, 0x100, 0x200)
    assert A.MF_WAIT == A.OPT_WAIT
    assert [
        A.PTP_OPT_ABORTING,
        A.PTP_OPT_BUFFERED,
        A.PTP_OPT_BLEND_LOW,
        A.PTP_OPT_BLEND_PREVIOUS,
        A.PTP_OPT_BLEND_NEXT,
        A.PTP_OPT_BLEND_HIGH,
    ] == [0x0000, 0x1000, 0x2000, 0x3000, 0x4000, 0x5000]
    assert [
        A.ITP_OPT_ABORT_BLEND,
        A.ITP_OPT_ABORT_FORCE,
        A.ITP_OPT_ABORT_STOP,
        A.ITP_OPT_BUFFERED,
        A.ITP_OPT_BLEND_DEC_EVENT,
        A.ITP_OPT_BLEND_RES_DIST,
        A.ITP_OPT_BLEND_RES_DIST_PERCENT,
    ] == [0x0000, 0x1000, 0x2000, 0x3000, 0x4000, 0x5000, 0x6000]
    for value in _consts(("PTP_OPT_", "ITP_OPT_")).values():
        assert value & ~A.OPT_BUFFER_MODE_MASK == 0


def test_stop_codes() -> None:
    assert (A.STOP_NORMAL, A.STOP_EMG, A.STOP_ALM, A.STOP_SVNO) == (0, 1, 2, 3)
    assert (A.STOP_PEL, A.STOP_MEL, A.STOP_SPEL, A.STOP_SMEL) == (4, 5, 6, 7)
    assert (A.STOP_USER_EMG, A.STOP_USER) == (8, 9)
    assert A.STOP_ERROR_LEVEL == 13
    assert (A.STOP_ORG_EL, A.STOP_NO_ORG, A.STOP_NO_EZ, A.STOP_BOTH_EL) == (20, 21, 22, 23)


def test_trigger_parameters() -> None:
    assert A.TGR_LCMP0_SRC == 0x00 and A.TGR_TCMP1_SRC == 0x03
    assert A.TGR_TCMP0_DIR == 0x04 and A.TGR_TRG_EN == 0x06
    for ch in range(4):
        assert getattr(A, f"TGR_TRG{ch}_SRC") == 0x10 + ch
        assert getattr(A, f"TGR_TRG{ch}_PWD") == 0x14 + ch
        assert getattr(A, f"TGR_TRG{ch}_LOGIC") == 0x18 + ch
        assert getattr(A, f"TGR_TRG{ch}_TGL") == 0x1C + ch
    assert (A.TIMR_ITV, A.TIMR_DIR, A.TIMR_RING_EN, A.TIMR_EN) == (0x20, 0x21, 0x22, 0x23)
    assert A.TGR_CMP_SRC_TIMER0 == 8 and A.TGR_CMP_SRC_DISABLED == 9


def test_sampling_vao_interrupts_and_device() -> None:
    assert (A.SAMP_PA_RATE, A.SAMP_PA_EDGE, A.SAMP_PA_LEVEL, A.SAMP_PA_TRIGCH) == (0, 2, 3, 5)
    assert (A.SAMP_PA_SRC_CH0, A.SAMP_PA_SRC_CH3) == (0x10, 0x13)
    assert A.SAMP_AXIS_MASK == 0xF00
    assert A.SAMP_MSTS_MDN == A.SAMP_MSTS_NSTP == A.SAMP_SRC_MSTS_MDN == 0x0A
    assert A.SAMP_SRC_ERR_POS == A.SAMP_ERROR_POS == 0x23
    assert A.SAMP_PTBUFF_COMP_ACC_F64 == 0x1D
    assert (A.VAO_TABLE_OUTPUT_TYPE, A.VAO_TABLE_INPUT_TYPE) == (0x00, 0x01)
    assert (A.VAO_TABLE_PWM_CONFIG, A.VAO_TABLE_SRC) == (0x10, 0x20)
    assert (A.IALM, A.IPEL, A.IMEL, A.IORG, A.IEZ, A.IINP, A.IEMG_AXIS) == (0, 1, 2, 3, 4, 5, 6)
    assert (A.ICSTP, A.IVM, A.IACC, A.IDEC, A.IMDN, A.IASTP) == (8, 9, 10, 11, 12, 13)
    assert (A.ISPEL, A.ISMEL, A.IPRED, A.IPOSTD) == (15, 16, 18, 19)
    assert (A.IEMG_SYS, A.ILCF0, A.ILCF1, A.IFCF0, A.IFCF1, A.IMOV, A.IHOV) == (0, 1, 2, 3, 4, 5, 6)
    assert (A.INT_ITEM_SYSTEM, A.INT_ITEM_DI_RISING, A.INT_ITEM_DI_FALLING) == (8, 9, 10)
    assert A.INT_NO_PER_BOARD == 352
    assert A.DEVICE_NAME_AMP_82548 == 14
    assert A.MAX_PT_DIM == 6
    assert (A.DEVICE_INFO_DRIVER, A.DEVICE_INFO_FPGA, A.DEVICE_INFO_PCB, A.DEVICE_INFO_DSP_KERNEL) == (
        0x10,
        0x21,
        0x30,
        0x40,
    )
    assert (A.INIT_MANUAL_ID, A.INIT_PARAM_LOAD_DEFAULT, A.INIT_PARAM_LOAD_FLASH) == (1, 0x10, 0x20)


# ------------------------------------------------------------------------------------------------------
# names unique where they must be: a number shared by several names only for the documented aliases
# ------------------------------------------------------------------------------------------------------

PRA_ALIASES = [
    {"PRA_ZSP_LOGIC", "PRA_INP_LOGIC"},
    {"PRA_SD_DEC", "PRA_STP_DEC"},
    {"PRA_SPEL_POS", "PRA_SPEL_POS0"},
    {"PRA_SMEL_POS", "PRA_SMEL_POS1"},
    {"PRA_HOME_CURVE", "PRA_HOME_S"},
    {"PRA_SF", "PRA_CURVE"},
    {"PRA_PT_STOP_ENDO", "PRA_PT_STP_DO_EN"},
    {"PRA_PT_STOP_DO", "PRA_PT_STP_DO"},
    {"PRA_JG_SF", "PRA_JG_CURVE"},
    {"PRA_JG_OFFSET", "PRA_JG_STEP"},
    {"PRA_SINP_STBL", "PRA_SINP_STBT"},
    {"PRA_ENCODER_MODE", "PRA_PLS_IPT_MODE"},
    {"PRA_PULSE_OUT_MODE", "PRA_PLS_OPT_MODE"},
    {"PRA_ENC_FILTER", "PRA_ENCODER_FILTER"},
    {"PRA_KFF_GAIN", "PRA_KVFF_GAIN"},
    {"PRA_KP_SHIFT", "PRA_VOLTAGE_MAX"},
    {"PRA_KI_SHIFT", "PRA_VOLTAGE_MIN"},
    {"PRA_V_OFFSET", "PRA_SERVO_V_BIAS"},
    {"PRA_SAT_LIMIT", "PRA_SERVO_V_LIMIT"},
    {"PRA_ERR_POS_LEVEL", "PRA_ERR_C_LEVEL"},
    {"PRA_V_INVERSE", "PRA_SERVO_V_INVERSE"},
]


def test_axis_parameter_numbers_shared_only_by_aliases() -> None:
    shared = [names for names in _by_value("PRA_", exclude=frozenset({"PRA_NAMES", "PRA_AMP_USED"})).values()]
    assert sorted(map(sorted, (n for n in shared if len(n) > 1))) == sorted(map(sorted, PRA_ALIASES))


def test_board_parameter_numbers_shared_only_by_aliases() -> None:
    shared = [n for n in _by_value(("PRB_", "PRS_")).values() if len(n) > 1]
    assert sorted(map(sorted, shared)) == [
        ["PRB_EMG_LOGIC", "PRS_EMG_LOGIC"],
        ["PRB_WDT0_LIMIT", "PRB_WDT0_VALUE"],
    ]


@pytest.mark.parametrize(
    ("names", "aliases"),
    [
        ([n for n in _consts("ERR_")], []),
        ([n for n in _consts("STOP_")], []),
        ([n for n in _consts("MIO_") if not n.endswith("_V")], []),
        ([n for n in _consts("PTP_OPT_")], []),
        ([n for n in _consts("ITP_OPT_")], []),
        (
            [n for n in _consts("TGR_") if re.fullmatch(r"TGR_(LCMP|TCMP|TRG)\w+", n)]
            + [n for n in _consts("TIMR_")],
            [],
        ),
        (["IALM", "IPEL", "IMEL", "IORG", "IEZ", "IINP", "IEMG_AXIS", "ICSTP", "IVM", "IACC", "IDEC",
          "IMDN", "IASTP", "ISPEL", "ISMEL", "IPRED", "IPOSTD"], []),
        (["IEMG_SYS", "ILCF0", "ILCF1", "IFCF0", "IFCF1", "IMOV", "IHOV"], []),
        (
            # the AMP's (PCI-8254/8) status block
            ["MTS_CSTP", "MTS_VM", "MTS_ACC", "MTS_DEC", "MTS_DIR", "MTS_MDN", "MTS_NSTP", "MTS_HMV",
             "MTS_WAIT", "MTS_PTB", "MTS_JOG", "MTS_ASTP", "MTS_BLD", "MTS_PRED", "MTS_POSTD", "MTS_GER"],
            [{"MTS_MDN", "MTS_NSTP"}],
        ),
        (
            [n for n in _consts("SAMP_") if not n.startswith(("SAMP_PA_", "SAMP_SRC_"))
             and n not in {"SAMP_AXIS_MASK", "SAMP_PARAM_MASK"}],
            [{"SAMP_MSTS_NSTP", "SAMP_MSTS_MDN"}, {"SAMP_ERROR_COUNTER", "SAMP_ERROR_POS"}],
        ),
        ([n for n in _consts("SAMP_PA_")], []),
    ],
)
def test_names_unique(names: list[str], aliases: list[set[str]]) -> None:
    groups: dict[int, set[str]] = defaultdict(set)
    for name in names:
        groups[getattr(A, name)].add(name)
    assert sorted(map(sorted, (g for g in groups.values() if len(g) > 1))) == sorted(map(sorted, aliases))


def test_no_stray_module_names() -> None:
    """The modules' loop variables do not leak, and every public name is upper case (or a mapping)."""
    public = [n for n in vars(A) if not n.startswith("_") and n != "annotations"]
    assert all(n.upper() == n or n.startswith(("ERR_", "VAO_TABLE_PWM_Config")) for n in public)


def test_no_daemon_imports() -> None:
    code = (
        "import sys, vdevmaps.aps_defs, vdevclient._aps_types\n"
        "bad = [m for m in sys.modules if m == 'vdevd' or m.startswith('vdevd.')]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


# ------------------------------------------------------------------------------------------------------
# the digest's tables
# ------------------------------------------------------------------------------------------------------


def test_spec_axis_parameter_table(spec: str) -> None:
    """§3.2: every row `| XXh/ddd | `PRA_…` (`alias`) | …` names constants of that number."""
    checked = 0
    for row in _table_rows(_section(spec, "### 3.2 Axis parameters")):
        m = re.fullmatch(r"([0-9A-F]+)h/(\d+)", row[0])
        if not m:
            continue
        number = int(m.group(1), 16)
        assert number == int(m.group(2)), row[0]
        names = BACKTICKED.findall(row[1])
        assert names, row
        for name in names:
            assert getattr(A, name) == number, name
            checked += 1
    assert checked >= 55


def test_spec_not_applicable_axis_parameters(spec: str) -> None:
    """§3.2 "Not applicable": each listed number has a name (so PRA_NAMES can report it)."""
    text = _section(spec, "### 3.2 Axis parameters")
    listed = text[text.index("Not applicable on the AMP") :]
    numbers = {0x82, 0x83, 0x84, 0x88, 0x0C, 0x0D, 0x0E, 0x0F, 0x16, 0x1A, 0x30, 0x31}
    numbers |= set(range(0x90, 0xA1)) | set(range(0x1C, 0x20)) | set(range(0x26, 0x2A))
    assert "82h-84h, 88h, 90h-A0h" in listed
    assert numbers <= set(A.PRA_NAMES)
    assert not numbers & A.PRA_AMP_USED


def test_spec_board_parameter_table(spec: str) -> None:
    rows = _table_rows(_section(spec, "### 3.1 Board parameters"))
    checked = 0
    for row in rows:
        if re.fullmatch(r"0x[0-9A-F]+", row[0]):
            # `PRB_WDT0_VALUE`/`LIMIT`: the second spelling abbreviated (PRB_WDT0_LIMIT, asserted above)
            for name in BACKTICKED.findall(row[1]):
                if name.startswith(("PRB_", "PRS_")):
                    assert getattr(A, name) == int(row[0], 16), name
                    checked += 1
    assert checked >= 7


def test_spec_status_table(spec: str) -> None:
    rows = _table_rows(_section(spec, "### 2.14 Motion status monitoring"))
    bits = {}
    stops = {}
    for row in rows:
        if len(row) >= 3 and row[0].isdigit():
            names = BACKTICKED.findall(row[2])
            if names and names[0].startswith("MTS_"):
                for name in names:
                    bits[name] = int(row[0])
            elif re.fullmatch(r"STOP_\w+", row[1]):
                stops[row[1]] = int(row[0])
    assert len(bits) == 16 and len(stops) == 19
    for name, bit in {**bits, **stops}.items():
        assert getattr(A, name) == bit, name


def test_spec_sampling_table(spec: str) -> None:
    rows = _table_rows(_section(spec, "### 2.19 Data sampling"))
    checked = 0
    for row in rows:
        if len(row) >= 2 and re.fullmatch(r"SAMP_\w+", row[0]) and re.fullmatch(r"0x[0-9A-F]+", row[1]):
            assert getattr(A, row[0]) == int(row[1], 16), row[0]
            checked += 1
    assert checked == 29
    text = _section(spec, "### 2.19 Data sampling")
    for name, value in re.findall(r"`(SAMP_PA_\w+)` (0x[0-9A-F]+)", text):
        assert getattr(A, name) == int(value, 16)


def test_spec_trigger_table(spec: str) -> None:
    rows = _table_rows(_section(spec, "### 2.16 High-speed position compare trigger"))
    checked = 0
    for row in rows:
        m = re.fullmatch(r"0x([0-9A-F]+)(?:-0x([0-9A-F]+))?", row[0])
        if not m:
            continue
        first, last = int(m.group(1), 16), int(m.group(2) or m.group(1), 16)
        for name in BACKTICKED.findall(row[1]):
            if "TRGx" in name:  # `TGR_TRGx_PWD` on a 0x14-0x17 row: one per channel
                for ch in range(last - first + 1):
                    concrete = name.replace("TRGx", f"TRG{ch}")
                    assert getattr(A, concrete) == first + ch, concrete
                    checked += 1
            elif first != last:  # `TGR_TRG0_SRC`…`TGR_TRG3_SRC`
                ch = int(re.search(r"TRG(\d)", name).group(1))  # type: ignore[union-attr]
                assert getattr(A, name) == first + ch, name
                checked += 1
            else:
                assert getattr(A, name) == first, name
                checked += 1
    assert checked == 25  # 7 + TRG0/TRG3_SRC + 3 x 4 channels + 4 TIMR_


def test_spec_option_tables(spec: str) -> None:
    text = _section(spec, "### 2.9 Point-to-point") + _section(spec, "### 2.13 Continuous interpolation")
    found = re.findall(r"`((?:PTP|ITP)_OPT_\w+)` (0x[0-9A-F]+)", text)
    assert len(found) == 13
    for name, value in found:
        assert getattr(A, name) == int(value, 16), name


def test_spec_return_codes(spec: str) -> None:
    text = _section(spec, "### 3.8 Return codes")
    found = re.findall(r"`-(\d+) (\w+)`", text)
    assert len(found) >= 25
    for number, suffix in found:
        assert getattr(A, f"ERR_{suffix}") == -int(number), suffix


def test_spec_interrupt_factors(spec: str) -> None:
    text = _section(spec, "### 2.23 Host interrupts")
    axis = text[text.index("Axis factors") : text.index("System factors")]
    system = text[text.index("System factors") : text.index("DI factors")]
    for number, name in re.findall(r"\b(\d+) (I[A-Z]+)\b", axis):
        assert getattr(A, "IEMG_AXIS" if name == "IEMG" else name) == int(number), name
    for number, name in re.findall(r"\b(\d+) (I[A-Z]+\d?)\b", system):
        assert getattr(A, "IEMG_SYS" if name == "IEMG" else name) == int(number), name


def test_spec_names_all_defined(spec: str) -> None:
    """Every constant-like name of the digest's families is defined (placeholders excepted)."""
    names = set(
        re.findall(
            r"\b((?:PRA|PRB|PRS|MTS|MIO|SAMP|TGR|STOP|ERR|OPT|PTP_OPT|ITP_OPT|INIT|VAO|TIMR|DEVICE_NAME|MAX)"
            r"_[A-Za-z0-9_]*[A-Za-z0-9])",
            spec,
        )
    )
    placeholders = {"PRB_PWMx_MAP_DO", "PRB_PWM0", "SAMP_SRC"}
    placeholders |= {"TGR_TRGx_PWD", "TGR_TRGx_LOGIC", "TGR_TRGx_TGL"}
    structures = {"SAMP_PARAM", "VAO_DATA"}  # type_def.h types, in vdevclient._aps_types
    missing = sorted(n for n in names - placeholders - structures if not hasattr(A, n))
    assert not missing
    for name in structures:
        assert issubclass(getattr(T, name), ctypes.Structure)


# ------------------------------------------------------------------------------------------------------
# structures: natural alignment, sizes and offsets derived by hand
# ------------------------------------------------------------------------------------------------------

LAYOUTS: dict[str, tuple[int, dict[str, int]]] = {
    "ASYNCALL": (
        2 * ctypes.sizeof(ctypes.c_void_p),
        {"h_event": 0, "i32_ret": ctypes.sizeof(ctypes.c_void_p)},
    ),
    "PTSTS": (12, {"BitSts": 0, "PntBufFreeSpace": 2, "PntBufUsageSpace": 4, "RunningCnt": 8}),
    "PTINFO": (28, {"Dimension": 0, "AxisArr": 4}),
    "PTDWL": (8, {"DwTime": 0}),
    "PTLINE": (56, {"Dim": 0, "Pos": 8}),
    "PTA2CA": (32, {"Index": 0, "Center": 8, "Angle": 24}),
    "PTA2CE": (48, {"Index": 0, "Center": 8, "End": 24, "Dir": 40}),
    "PTA3CA": (64, {"Index": 0, "Center": 8, "Normal": 32, "Angle": 56}),
    "PTA3CE": (64, {"Index": 0, "Center": 8, "End": 32, "Dir": 56}),
    "PTHCA": (80, {"Index": 0, "Center": 8, "Normal": 32, "Angle": 56, "DeltaH": 64, "FinalR": 72}),
    "PTHCE": (88, {"Index": 0, "Center": 8, "Normal": 32, "End": 56, "Dir": 80}),
    "SAMP_PARAM": (80, {"rate": 0, "edge": 4, "level": 8, "trigCh": 12, "sourceByCh": 16}),
    "STR_SAMP_DATA_4CH": (20, {"tick": 0, "data": 4}),
    "STR_SAMP_DATA_8CH": (36, {"tick": 0, "data": 4}),
    "LPSTS": (16, {"MotionLoopLoading": 0, "HostLoopLoading": 4, "MotionLoopLoadingMax": 8,
                   "HostLoopLoadingMax": 12}),
    "VAO_DATA": (156, {"outputType": 0, "inputType": 4, "config": 8, "inputSrc": 12, "minVel": 16,
                       "velInterval": 20, "totalPoints": 24, "mappingDataArr": 28}),
    "JOG_DATA": (28, {"i16_jogMode": 0, "i16_dir": 2, "i16_accType": 4, "i32_acc": 8, "i32_dec": 12,
                      "i32_maxSpeed": 16, "i32_offset": 20, "i32_delayTime": 24}),
}


@pytest.mark.skipif(ctypes.sizeof(ctypes.c_void_p) != 8, reason="offsets derived for a 64-bit host")
@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_structure_layout(name: str) -> None:
    cls = getattr(T, name)
    size, offsets = LAYOUTS[name]
    assert ctypes.sizeof(cls) == size
    assert [f[0] for f in cls._fields_] == list(offsets)
    for field, offset in offsets.items():
        assert getattr(cls, field).offset == offset, field


def test_structure_list_complete() -> None:
    structures = {n for n in T.__all__ if isinstance(getattr(T, n), type)
                  and issubclass(getattr(T, n), ctypes.Structure)}
    assert structures == set(LAYOUTS)


def test_scalar_types_have_windows_widths() -> None:
    widths = {"I8": 1, "U8": 1, "I16": 2, "U16": 2, "I32": 4, "U32": 4, "F32": 4, "F64": 8}
    for name, width in widths.items():
        assert ctypes.sizeof(getattr(T, name)) == width, name
    assert T.I32(-1).value == -1 and T.U32(-1).value == 0xFFFFFFFF


def test_structure_array_shapes() -> None:
    p = T.SAMP_PARAM()
    p.sourceByCh[7][1] = 3
    assert len(p.sourceByCh) == A.MAX_SAMPL_CH and len(p.sourceByCh[0]) == A.MAX_SAMPL_SRC
    line = T.PTLINE(2, (T.F64 * A.MAX_PT_DIM)(1.0, 2.0))
    assert line.Dim == 2 and list(line.Pos) == [1.0, 2.0, 0.0, 0.0, 0.0, 0.0]
    assert len(T.VAO_DATA().mappingDataArr) == 32
    assert len(T.PTHCE().Index) == 3 and len(T.PTA2CE().End) == 2
    assert len(T.PTINFO().AxisArr) == A.MAX_PT_DIM
