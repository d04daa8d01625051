"""The ADLINK APS library's constants for the AMP-204C / AMP-208C (spec adlink.md §1-§4, §6).

Plain module-level ints, shared by the daemon (`vdevd`) and the client library (`vdevclient`): the
names are ADLINK's (`APS_Define.h` [X2], `ErrorCodesDef.h` [X4], `type_def.h` [X3]) wherever ADLINK has
one, with the value ADLINK uses; each group cites its source. Where ADLINK has no name (the spec
describes a value only), the name is a vdevd choice and says so; a value that is not documented by
ADLINK or the manual is marked `# vdevd choice`.

Citation keys are the spec's (§0): [M §x.y] the AMP-204C/208C user manual rev 2.00; [X1] APS168.h;
[X2] APS_Define.h; [X3] type_def.h; [X4] ErrorCodesDef.h; [X5] ADLINK's PCI-8254/8 samples; [X6] the
compare-trigger sample; [X7] the third-party transcription of the function-library manual; [X8] the
stop-code tables in ADLINK's samples.
"""

from __future__ import annotations

# =====================================================================================================
# Return codes [X4], spec §3.8. Every APS function returns I32: 0 = ERR_NoError, negative = error.
# =====================================================================================================
ERR_NoError = 0
# system errors (-1 ... -1000)
ERR_OSVersion = -1
ERR_OpenDriverFailed = -2
ERR_InsufficientMemory = -3
ERR_DeviceNotInitial = -4
ERR_NoDeviceFound = -5
ERR_CardIdDuplicate = -6
ERR_DeviceAlreadyInitialed = -7
ERR_InterruptNotEnable = -8
ERR_TimeOut = -9
ERR_ParametersInvalid = -10
ERR_SetEEPROM = -11
ERR_GetEEPROM = -12
ERR_FunctionNotAvailable = -13
ERR_FirmwareError = -14
ERR_CommandInProcess = -15
ERR_AxisIdDuplicate = -16
ERR_ModuleNotFound = -17
ERR_InsufficientModuleNo = -18
ERR_HandShakeFailed = -19
ERR_FILE_FORMAT = -20
ERR_ParametersReadOnly = -21
ERR_DistantNotEnough = -22
ERR_FunctionNotEnable = -23
ERR_ServerAlreadyClose = -24
ERR_DllNotFound = -25
# AI16AO2 calibration (-26 ... -31) [X4]
ERR_TrimDAC_Channel = -26
ERR_Satellite_Type = -27
ERR_Over_Voltage_Spec = -28
ERR_Over_Current_Spec = -29
ERR_SlaveIsNotAI = -30
ERR_Over_AO_Channel_Scope = -31
ERR_DllFuncFailed = -32
ERR_FeederAbnormalStop = -33
ERR_Read_ModuleType_Dismatch = -34
ERR_Win32Error = -1000
#: base of the DSP errors (-2001 ... -3000)
ERR_DspStart = -2000

#: return code -> name
ERR_NAMES: dict[int, str] = {
    _value: _name for _name, _value in list(globals().items()) if _name.startswith("ERR_")
}

# =====================================================================================================
# APS_initial Mode bits [X2], spec §3.7; bit 9 from [X7] (no ADLINK name in [X2])
# =====================================================================================================
INIT_AUTO_CARD_ID = 0x00  # bit 0 = 0: card ID assigned by the system
INIT_MANUAL_ID = 0x01  # bit 0 = 1: card ID from the DIP switch
INIT_PARALLEL_FIXED = 0x02  # bit 1: fixed axis indexing, parallel type
INIT_SERIES_FIXED = 0x04  # bit 2: fixed axis indexing, series type
INIT_NOT_RESET_DO = 0x08  # bit 3: HSL DO not reset
INIT_PARAM_IGNORE = 0x00  # bits 4-5: keep the current parameters
INIT_PARAM_LOAD_DEFAULT = 0x10  # bits 4-5: load the defaults
INIT_PARAM_LOAD_FLASH = 0x20  # bits 4-5: load from flash
INIT_MNET_INTERRUPT = 0x40  # bit 6: MNET interrupt mode
#: bit 9 (PCI-8254/58, AMP-204/8C): 0 MDN on CSTP or ASTP (default), 1 MDN on CSTP only [X7];
#: the name is a vdevd choice (ADLINK's headers name no constant for it)
INIT_MDN_CSTP_ONLY = 0x200

# =====================================================================================================
# Board parameters, APS_set_board_param / APS_get_board_param [X2], spec §3.1
# =====================================================================================================
PRB_EMG_LOGIC = 0x00  # EMG input logic: 0 not inverted, 1 inverted [M §4.1.1.4]
PRS_EMG_LOGIC = PRB_EMG_LOGIC  # the manual's spelling [M §4.1.1.4]
PRB_WDT0_VALUE = 0x10  # watchdog limit (older [X2])
PRB_WDT0_LIMIT = PRB_WDT0_VALUE  # newer [X2] name
PRB_WDT0_COUNTER = 0x11  # reset / read the watchdog counter
PRB_WDT0_UNIT = 0x12
PRB_WDT0_ACTION = 0x13
PRB_DO_LOGIC = 0x14  # DO word: 0 not inverted, 1 inverted
PRB_DI_LOGIC = 0x15  # DI word: 0 not inverted, 1 inverted
# DO-gated PWM [M §4.9.3.6, Table 4-3], [X2]: -1 off (default); bits 0-7 DO channel, bit 8 logic
PRB_PWM0_MAP_DO = 0x110
PRB_PWM1_MAP_DO = 0x111
PRB_PWM2_MAP_DO = 0x112
PRB_PWM3_MAP_DO = 0x113
#: the motion control cycle in µs (500 / 1000 / 2000; spec Q1 proposes a vdevd-reserved range): ADLINK
#: documents no parameter for it
PRB_VDEVD_MOTION_CYCLE = 0x8000  # vdevd choice (name and number)

#: number -> primary name of the board parameters (the first name bound to a number)
PRB_NAMES: dict[int, str] = {}
for _name, _value in list(globals().items()):
    if _name.startswith(("PRB_", "PRS_")) and isinstance(_value, int):
        PRB_NAMES.setdefault(_value, _name)
del _name, _value

# values of PRB_PWMx_MAP_DO [M §4.9.3.6]; the names are vdevd choices
PWM_MAP_DO_DISABLED = -1
PWM_MAP_DO_CH_MASK = 0xFF  # bits 0-7: DO channel 0-7
PWM_MAP_DO_LOGIC = 0x100  # bit 8 = 1: DO on -> PWM enabled; 0: inverse

# =====================================================================================================
# Axis parameters, APS_set_axis_param(_f) / APS_get_axis_param(_f) [X2], spec §3.2. Aliases follow
# their primary name (the spec's first-listed name); PRA_NAMES maps a number to the primary name.
# =====================================================================================================
# -- I/O logic and stop modes [M §4.1.1.4], [M §4.10] --
PRA_EL_LOGIC = 0x00
PRA_ORG_LOGIC = 0x01
PRA_EL_MODE = 0x02  # EL (and soft-EL) stop mode
PRA_MDM_CONDI = 0x03  # motion-done condition [X2 only]
PRA_ALM_LOGIC = 0x04
PRA_ZSP_LOGIC = 0x05  # INP logic on the AMP [M §4.1.1.4]
#: the manual's name for 05h. CONFLICT: [X2] also has a PRA_INP_LOGIC = 0x211 for the PCI-8154/58;
#: on the AMP-204C/208C the manual's 05h is the one (spec §3.2)
PRA_INP_LOGIC = PRA_ZSP_LOGIC
PRA_EZ_LOGIC = 0x06
PRA_SD_DEC = 0x07  # APS_stop_move deceleration [M §4.6.1]
PRA_STP_DEC = PRA_SD_DEC  # [X2] name
# -- soft limits [M §4.10.2.1] --
PRA_SPEL_EN = 0x08
PRA_SMEL_EN = 0x09
PRA_SPEL_POS = 0x0A
PRA_SMEL_POS = 0x0B
PRA_SPEL_POS0 = PRA_SPEL_POS  # the manual's misprint [M §4.10.2.1]
PRA_SMEL_POS1 = PRA_SMEL_POS  # the manual's misprint
# -- homing [M §4.3] --
PRA_HOME_MODE = 0x10
PRA_HOME_DIR = 0x11
PRA_HOME_CURVE = 0x12  # home S-factor
PRA_HOME_S = PRA_HOME_CURVE  # the manual's mode-table name [M §4.3]
PRA_HOME_ACC = 0x13
PRA_HOME_VS = 0x14
PRA_HOME_VM = 0x15
PRA_HOME_SHIFT = 0x17
PRA_HOME_EZA = 0x18
PRA_HOME_VO = 0x19
PRA_HOME_POS = 0x1B
# -- move profile [M §4.2.3], [M §4.6.1] --
PRA_SF = 0x20
PRA_CURVE = PRA_SF
PRA_ACC = 0x21
PRA_DEC = 0x22
PRA_VS = 0x23
PRA_VM = 0x24
PRA_VE = 0x25
PRA_PRE_EVENT_DIST = 0x2A  # [M §4.8.1]
PRA_POST_EVENT_DIST = 0x2B
# -- point-table / ASTP output actions [X2 only] --
PRA_PT_STOP_ENDO = 0x32
PRA_PT_STP_DO_EN = PRA_PT_STOP_ENDO  # newer [X2] name
PRA_PT_STOP_DO = 0x33
PRA_PT_STP_DO = PRA_PT_STOP_DO  # newer [X2] name
PRA_PWM_OFF = 0x34
PRA_DO_OFF = 0x35
# -- jog [M §4.5] --
PRA_JG_MODE = 0x40
PRA_JG_DIR = 0x41
PRA_JG_SF = 0x42
PRA_JG_CURVE = PRA_JG_SF  # [X2] name
PRA_JG_ACC = 0x43
PRA_JG_DEC = 0x44
PRA_JG_VM = 0x45
PRA_JG_OFFSET = 0x46
PRA_JG_STEP = PRA_JG_OFFSET  # [X2] name
PRA_JG_DELAY = 0x47
PRA_JG_MAP_DI_EN = 0x48
PRA_JG_P_JOG_DI = 0x49
PRA_JG_N_JOG_DI = 0x4A
PRA_JG_JOG_DI = 0x4B
# -- motion done / soft INP / servo [X2 only] --
PRA_MDN_DELAY = 0x50
PRA_SINP_WDW = 0x51
PRA_SINP_STBL = 0x52
PRA_SINP_STBT = PRA_SINP_STBL  # newer [X2] name
PRA_SERVO_LOGIC = 0x53
# -- gearing and gantry [M §4.9.1] --
PRA_GEAR_MASTER = 0x60
PRA_GEAR_ENGAGE_RATE = 0x61
PRA_GEAR_RATIO = 0x62
PRA_GANTRY_PROTECT_1 = 0x63
PRA_GANTRY_PROTECT_2 = 0x64
# -- encoder, pulse output, unit factor [M §4.1.1.2-3], [M §4.2.2] --
PRA_ENCODER_MODE = 0x80  # the manual's name
PRA_PLS_IPT_MODE = PRA_ENCODER_MODE  # [X2] name
PRA_PULSE_OUT_MODE = 0x81  # the manual's name
PRA_PLS_OPT_MODE = PRA_PULSE_OUT_MODE  # [X2] name
PRA_ENCODER_DIR = 0x85
PRA_POS_UNIT_FACTOR = 0x86  # unnamed in the manual; [X2] name
# -- position error protection [M §4.10.2.2] --
PRA_ERR_POS_LEVEL = 0x124
PRA_ERR_C_LEVEL = PRA_ERR_POS_LEVEL  # older [X2] name

# -- not applicable on the AMP (closed loop, analog, other cards): accepted and stored, no effect
# (spec §3.2 "Not applicable", ASSUMPTION); names and numbers [X2] --
PRA_EFB_CONDI0 = 0x0C
PRA_EFB_CONDI1 = 0x0D
PRA_EFB_SRC0 = 0x0E
PRA_EFB_SRC1 = 0x0F
PRA_HOME_VA = 0x16
PRA_HOME_OFFSET = 0x1A
PRA_HOME_TORQUE = 0x1C
PRA_HOME_EZ_DIR = 0x1D
PRA_HOME_SEARCH_TARGET = 0x1E
PRA_HOME_DOWN_COUNTER = 0x1F
PRA_SACC = 0x26
PRA_SDEC = 0x27
PRA_ACC_SR = 0x28
PRA_DEC_SR = 0x29
PRA_DIST = 0x30
PRA_MAX_VELOCITY = 0x31
PRA_EGEAR_MASTER = 0x65
PRA_EGEAR_SOURCE = 0x66
PRA_MAX_E_LIMIT = 0x82
PRA_ENC_FILTER = 0x83
PRA_ENCODER_FILTER = PRA_ENC_FILTER
PRA_EGEAR = 0x84
PRA_MOVE_RATIO = 0x88
PRA_KP_GAIN = 0x90
PRA_KI_GAIN = 0x91
PRA_KD_GAIN = 0x92
PRA_KFF_GAIN = 0x93
PRA_KVFF_GAIN = PRA_KFF_GAIN
PRA_KVGTY_GAIN = 0x94
PRA_KPGTY_GAIN = 0x95
PRA_IKP_GAIN = 0x96
PRA_IKI_GAIN = 0x97
PRA_IKD_GAIN = 0x98
PRA_IKFF_GAIN = 0x99
PRA_KAFF_GAIN = 0x9A
PRA_KP_SHIFT = 0x9B
PRA_VOLTAGE_MAX = PRA_KP_SHIFT  # "V2" name for 9Bh [X2]
PRA_KI_SHIFT = 0x9C
PRA_VOLTAGE_MIN = PRA_KI_SHIFT  # "V2" name for 9Ch [X2]
PRA_KD_SHIFT = 0x9D
PRA_KVFF_SHIFT = 0x9E
PRA_KAFF_SHIFT = 0x9F
PRA_PID_SHIFT = 0xA0
PRA_M_INTERFACE = 0x100
PRA_M_VOL_RANGE = 0x110
PRA_M_MAX_SPEED = 0x111
PRA_M_ENC_RES = 0x112
PRA_V_OFFSET = 0x120
PRA_SERVO_V_BIAS = PRA_V_OFFSET
PRA_DZ_LOW = 0x121
PRA_DZ_UP = 0x122
PRA_SAT_LIMIT = 0x123
PRA_SERVO_V_LIMIT = PRA_SAT_LIMIT
PRA_V_INVERSE = 0x125
PRA_SERVO_V_INVERSE = PRA_V_INVERSE
PRA_DZ_VAL = 0x126
PRA_IW_MAX = 0x127
PRA_IW_MIN = 0x128
PRA_BKL_DIST = 0x129
PRA_BKL_CNSP = 0x12A
PRA_INTEGRAL_LIMIT = 0x12B
PRA_D_SAMPLE_TIME = 0x12C
PRA_PSR_LINK = 0x130
PRA_PSR_RATIO = 0x131
PRA_BIQUAD0_A1 = 0x132
PRA_BIQUAD0_A2 = 0x133
PRA_BIQUAD0_B0 = 0x134
PRA_BIQUAD0_B1 = 0x135
PRA_BIQUAD0_B2 = 0x136
PRA_BIQUAD0_DIV = 0x137
PRA_BIQUAD1_A1 = 0x138
PRA_BIQUAD1_A2 = 0x139
PRA_BIQUAD1_B0 = 0x13A
PRA_BIQUAD1_B1 = 0x13B
PRA_BIQUAD1_B2 = 0x13C
PRA_BIQUAD1_DIV = 0x13D
PRA_FRIC_GAIN = 0x13E
PRA_DA_TYPE = 0x140
PRA_CONTROL_MODE = 0x141

#: number -> primary name, for every axis parameter above: an alias is always defined after its
#: primary name, so the first name bound to a number is the primary one
PRA_NAMES: dict[int, str] = {}
for _name, _value in list(globals().items()):
    if _name.startswith("PRA_") and isinstance(_value, int):
        PRA_NAMES.setdefault(_value, _name)
del _name, _value

#: the parameters the AMP-204C/208C implements (spec §3.2 table); the others are stored only
PRA_AMP_USED: frozenset[int] = frozenset(
    {
        *range(0x00, 0x0C),
        *range(0x10, 0x16),
        *range(0x17, 0x1A),
        0x1B,
        *range(0x20, 0x26),
        0x2A,
        0x2B,
        *range(0x32, 0x36),
        *range(0x40, 0x4C),
        *range(0x50, 0x54),
        *range(0x60, 0x65),
        0x80,
        0x81,
        0x85,
        0x86,
        0x124,
    }
)

# =====================================================================================================
# Motion status bits, APS_motion_status [X2 "Following definition for PCI-8254/8"], spec §2.14.
# Bit numbers; the *_V masks are 1 << bit.
# =====================================================================================================
MTS_CSTP = 0  # command stop
MTS_VM = 1  # at maximum velocity
MTS_ACC = 2  # accelerating
MTS_DEC = 3  # decelerating
MTS_DIR = 4  # last direction, 1 positive
MTS_MDN = 5  # motion done (may be an abnormal stop)
MTS_NSTP = MTS_MDN  # [X2] general name
MTS_HMV = 6  # homing
MTS_WAIT = 10  # waiting for APS_move_trigger
MTS_PTB = 11  # point-buffer motion
MTS_JOG = 15  # jogging
MTS_ASTP = 16  # abnormal stop
MTS_BLD = 17  # blending
MTS_PRED = 18  # pre-distance event
MTS_POSTD = 19  # post-distance event
MTS_GER = 28  # geared slave
MTS_CSTP_V = 1 << MTS_CSTP
MTS_VM_V = 1 << MTS_VM
MTS_ACC_V = 1 << MTS_ACC
MTS_DEC_V = 1 << MTS_DEC
MTS_DIR_V = 1 << MTS_DIR
MTS_MDN_V = 1 << MTS_MDN
MTS_NSTP_V = MTS_MDN_V
MTS_HMV_V = 1 << MTS_HMV
MTS_WAIT_V = 1 << MTS_WAIT
MTS_PTB_V = 1 << MTS_PTB
MTS_JOG_V = 1 << MTS_JOG
MTS_ASTP_V = 1 << MTS_ASTP
MTS_BLD_V = 1 << MTS_BLD
MTS_PRED_V = 1 << MTS_PRED
MTS_POSTD_V = 1 << MTS_POSTD
MTS_GER_V = 1 << MTS_GER

# the general [X2] block for other cards (PCI-8253/56, ...): the same bits mean other things there;
# listed so that code ported from other cards resolves, never set by the AMP (spec §2.14 Notes)
MTS_SMV = 7  # single-axis move
MTS_LIP = 8  # linear interpolation
MTS_CIP = 9  # circular interpolation
MTS_VS = 10  # at start velocity (AMP: MTS_WAIT)
MTS_PMV = 11  # point-table move (AMP: MTS_PTB)
MTS_PDW = 12
MTS_PPS = 13
MTS_SLV = 14
MTS_SVONS = 17  # (AMP: MTS_BLD)
MTS_EMGS = 18  # (AMP: MTS_PRED)
MTS_ALMS = 19  # (AMP: MTS_POSTD)
MTS_WANS = 20
MTS_PELS = 21
MTS_MELS = 22
MTS_ECES = 23
MTS_SPELS = 24
MTS_SMELS = 25
MTS_STPOA = 26
MTS_GDCES = 27
MTS_GTM = 28  # (AMP: MTS_GER)
MTS_PAPB = 29

# =====================================================================================================
# Motion I/O bits, APS_motion_io_status [X2], spec §2.1. Bits 8-10 and 13-17 are other cards' and
# read 0 on the AMP (ASSUMPTION). Bit numbers; the *_V masks are 1 << bit.
# =====================================================================================================
MIO_ALM = 0
MIO_PEL = 1
MIO_MEL = 2
MIO_ORG = 3
MIO_EMG = 4
MIO_EZ = 5
MIO_INP = 6
MIO_SVON = 7  # output state
MIO_RDY = 8
MIO_WARN = 9
MIO_ZSP = 10
MIO_SPEL = 11  # soft PEL condition
MIO_SMEL = 12  # soft MEL condition
MIO_TLC = 13
MIO_ABSL = 14
MIO_STA = 15
MIO_PSD = 16
MIO_MSD = 17
MIO_ALM_V = 1 << MIO_ALM
MIO_PEL_V = 1 << MIO_PEL
MIO_MEL_V = 1 << MIO_MEL
MIO_ORG_V = 1 << MIO_ORG
MIO_EMG_V = 1 << MIO_EMG
MIO_EZ_V = 1 << MIO_EZ
MIO_INP_V = 1 << MIO_INP
MIO_SVON_V = 1 << MIO_SVON
MIO_RDY_V = 1 << MIO_RDY
MIO_WARN_V = 1 << MIO_WARN
MIO_ZSP_V = 1 << MIO_ZSP
MIO_SPEL_V = 1 << MIO_SPEL
MIO_SMEL_V = 1 << MIO_SMEL
MIO_TLC_V = 1 << MIO_TLC
MIO_ABSL_V = 1 << MIO_ABSL
MIO_STA_V = 1 << MIO_STA
MIO_PSD_V = 1 << MIO_PSD
MIO_MSD_V = 1 << MIO_MSD

# =====================================================================================================
# Option word of the motion functions [X2], spec §3.6, §2.9, §2.13, §2.20 ([M §4.9.5.1])
# =====================================================================================================
OPT_ABSOLUTE = 0x0000  # bit 0 = 0
OPT_RELATIVE = 0x0001  # bit 0 = 1
OPT_WAIT = 0x0100  # bit 8: wait for APS_move_trigger (the manual's MF_WAIT)
MF_WAIT = OPT_WAIT  # the manual's name [M §4.8.1]
OPT_FORCE_ABORT = 0x0200  # bit 9, newer [X2]; accepted and ignored (spec §3.6)
#: bits 12-15: buffer / transition mode (vdevd names for the mask)
OPT_BUFFER_MODE_MASK = 0xF000
# PTP buffer modes [X2], spec §2.9
PTP_OPT_ABORTING = 0x0000
PTP_OPT_BUFFERED = 0x1000
PTP_OPT_BLEND_LOW = 0x2000
PTP_OPT_BLEND_PREVIOUS = 0x3000
PTP_OPT_BLEND_NEXT = 0x4000
PTP_OPT_BLEND_HIGH = 0x5000
# interpolation transition modes [X2], spec §2.13
ITP_OPT_ABORT_BLEND = 0x0000
ITP_OPT_ABORT_FORCE = 0x1000
ITP_OPT_ABORT_STOP = 0x2000
ITP_OPT_BUFFERED = 0x3000
ITP_OPT_BLEND_DEC_EVENT = 0x4000
ITP_OPT_BLEND_RES_DIST = 0x5000
ITP_OPT_BLEND_RES_DIST_PERCENT = 0x6000

# =====================================================================================================
# Stop codes, APS_get_stop_code [M §4.10], [X8], spec §2.14 table
# =====================================================================================================
STOP_NORMAL = 0
STOP_EMG = 1
STOP_ALM = 2
STOP_SVNO = 3  # servo off
STOP_PEL = 4
STOP_MEL = 5
STOP_SPEL = 6
STOP_SMEL = 7
STOP_USER_EMG = 8  # APS_emg_stop
STOP_USER = 9  # APS_stop_move
STOP_GAN_L1 = 10
STOP_GAN_L2 = 11
STOP_GEAR_SLAVE = 12
STOP_ERROR_LEVEL = 13  # [X8]; the manual prints 6 (CONFLICT, spec Q9)
STOP_DI = 14  # other cards [X8 user header]
STOP_ORG_EL = 20
STOP_NO_ORG = 21
STOP_NO_EZ = 22
STOP_BOTH_EL = 23

# =====================================================================================================
# Trigger parameters, APS_set_trigger_param / APS_get_trigger_param [X2 "Only for PCI-8258"],
# [M §4.9.2], spec §2.16, §3.3
# =====================================================================================================
TGR_LCMP0_SRC = 0x00
TGR_LCMP1_SRC = 0x01
TGR_TCMP0_SRC = 0x02
TGR_TCMP1_SRC = 0x03
TGR_TCMP0_DIR = 0x04
TGR_TCMP1_DIR = 0x05
TGR_TRG_EN = 0x06  # TRG0-3 output enable, bit n = TRGn
TGR_TRG0_SRC = 0x10
TGR_TRG1_SRC = 0x11
TGR_TRG2_SRC = 0x12
TGR_TRG3_SRC = 0x13
TGR_TRG0_PWD = 0x14  # pulse width (N - 1) x 20 ns [X7]
TGR_TRG1_PWD = 0x15
TGR_TRG2_PWD = 0x16
TGR_TRG3_PWD = 0x17
TGR_TRG0_LOGIC = 0x18
TGR_TRG1_LOGIC = 0x19
TGR_TRG2_LOGIC = 0x1A
TGR_TRG3_LOGIC = 0x1B
TGR_TRG0_TGL = 0x1C  # 0 pulse, 1 toggle
TGR_TRG1_TGL = 0x1D
TGR_TRG2_TGL = 0x1E
TGR_TRG3_TGL = 0x1F
TIMR_ITV = 0x20  # timer interval N x 100 ns [X7]
TIMR_DIR = 0x21  # 0 up, 1 down
TIMR_RING_EN = 0x22
TIMR_EN = 0x23

# values of TGR_LCMPx_SRC / TGR_TCMPx_SRC [X7]: 0-7 = encoder counter of axis n; the names are vdevd
# choices
TGR_CMP_SRC_ENCODER0 = 0  # + axis number, 0-7
TGR_CMP_SRC_TIMER0 = 8
TGR_CMP_SRC_DISABLED = 9
# values of TGR_TCMPx_DIR [X7], [X6]; the names are vdevd choices
TGR_CMP_DIR_NEGATIVE = 0
TGR_CMP_DIR_POSITIVE = 1
TGR_CMP_DIR_BIDIR = 2
# bits of TGR_TRGx_SRC [X7], [X6]; the names are vdevd choices (bit 1 is reserved)
TGR_SRC_MANUAL = 0x001
TGR_SRC_FCMP0 = 0x004  # = TCMP0
TGR_SRC_FCMP1 = 0x008  # = TCMP1
TGR_SRC_LCMP0 = 0x010
TGR_SRC_LCMP1 = 0x020
TGR_SRC_MCMP = 0x040
TGR_SRC_FCMP2 = 0x080  # not on the AMP
TGR_SRC_FCMP3 = 0x100  # not on the AMP
TGR_SRC_LCMP2 = 0x200  # not on the AMP
TGR_SRC_LCMP3 = 0x400  # not on the AMP

# =====================================================================================================
# VAO (laser power) parameters, APS_set_vao_param [M §4.9.3.5], spec §2.17. The names are the
# manual's; N = table 0-7, so the parameter number is base + 2N (output/input type) or base + N.
# =====================================================================================================
VAO_TABLE_OUTPUT_TYPE = 0x00  # + 2N: 1 / 2 / 3, default 1
VAO_TABLE_INPUT_TYPE = 0x01  # + 2N: 0 feedback speed, 1 command speed, default 0
VAO_TABLE_PWM_CONFIG = 0x10  # + N: Hz / ns / N x 0.05 %, default 100 (the manual: VAO_TABLE_PWM_Config)
VAO_TABLE_PWM_Config = VAO_TABLE_PWM_CONFIG
VAO_TABLE_SRC = 0x20  # + N: axis bit mask, bits 0-3 = axes 0-3, default 0x01
VAO_TABLE_COUNT = 8
VAO_TABLE_MAX_POINTS = 32  # [M §4.9.3.7]
# values of VAO_TABLE_OUTPUT_TYPE [M §4.9.3.2]; the names are vdevd choices
VAO_OUTPUT_FIX_FREQUENCY = 1  # table gives the duty (0-2000 x 0.05 %)
VAO_OUTPUT_FIX_WIDTH = 2  # table gives the frequency
VAO_OUTPUT_FIX_DUTY = 3  # table gives the frequency
# values of VAO_TABLE_INPUT_TYPE; the names are vdevd choices
VAO_INPUT_FEEDBACK = 0
VAO_INPUT_COMMAND = 1

# PWM ranges of APS_set_pwm_frequency / APS_set_pwm_width [X5], spec §2.17; names vdevd choices
PWM_FREQUENCY_MIN, PWM_FREQUENCY_MAX = 3, 50_000_000  # Hz
PWM_WIDTH_MIN, PWM_WIDTH_MAX = 20, 335_544_300  # ns

# =====================================================================================================
# Data sampling [X2], spec §2.19 (Table 4-4 [M §4.9.4])
# =====================================================================================================
# APS_set_sampling_param parameter numbers
SAMP_PA_RATE = 0x0
SAMP_PA_EDGE = 0x2
SAMP_PA_LEVEL = 0x3
SAMP_PA_TRIGCH = 0x5
SAMP_PA_SRC_CH0 = 0x10
SAMP_PA_SRC_CH1 = 0x11
SAMP_PA_SRC_CH2 = 0x12
SAMP_PA_SRC_CH3 = 0x13
# a single I32 source word: the axis in bits 8-11, the signal in bits 0-7
SAMP_AXIS_MASK = 0xF00
SAMP_PARAM_MASK = 0xFF
# sampling sources: [X2] names (the manual's SAMP_SRC_* aliases follow)
SAMP_COM_POS = 0x00
SAMP_FBK_POS = 0x01
SAMP_CMD_VEL = 0x02
SAMP_FBK_VEL = 0x03
SAMP_MIO = 0x04
SAMP_MSTS = 0x05
SAMP_MSTS_ACC = 0x06
SAMP_MSTS_MV = 0x07
SAMP_MSTS_DEC = 0x08
SAMP_MSTS_CSTP = 0x09
SAMP_MSTS_NSTP = 0x0A
SAMP_MSTS_MDN = SAMP_MSTS_NSTP
SAMP_MIO_INP = 0x0B
SAMP_MIO_ZERO = 0x0C
SAMP_MIO_ORG = 0x0D
SAMP_COM_POS_F64 = 0x10
SAMP_FBK_POS_F64 = 0x11
SAMP_CMD_VEL_F64 = 0x12
SAMP_FBK_VEL_F64 = 0x13
SAMP_CONTROL_VOL_F64 = 0x14
SAMP_ERR_POS_F64 = 0x15
SAMP_PWM_FREQUENCY_F64 = 0x18
SAMP_PWM_DUTY_CYCLE_F64 = 0x19
SAMP_PWM_WIDTH_F64 = 0x1A
SAMP_VAO_COMP_VEL_F64 = 0x1B
SAMP_PTBUFF_COMP_VEL_F64 = 0x1C
SAMP_PTBUFF_COMP_ACC_F64 = 0x1D
SAMP_CONTROL_VOL = 0x20
SAMP_GTY_DEVIATION = 0x21
SAMP_ENCODER_RAW = 0x22
SAMP_ERROR_COUNTER = 0x23
SAMP_ERROR_POS = SAMP_ERROR_COUNTER
SAMP_PTBUFF_RUN_INDEX = 0x24
# the manual's spellings [M §4.9.4, Table 4-4]
SAMP_SRC_COM_POS = SAMP_COM_POS
SAMP_SRC_FBK_POS = SAMP_FBK_POS
SAMP_SRC_CMD_VEL = SAMP_CMD_VEL
SAMP_SRC_FBK_VEL = SAMP_FBK_VEL
SAMP_SRC_MIO = SAMP_MIO
SAMP_SRC_MSTS = SAMP_MSTS
SAMP_SRC_MSTS_ACC = SAMP_MSTS_ACC
SAMP_SRC_MSTS_MV = SAMP_MSTS_MV
SAMP_SRC_MSTS_DEC = SAMP_MSTS_DEC
SAMP_SRC_MSTS_CSTP = SAMP_MSTS_CSTP
SAMP_SRC_MSTS_MDN = SAMP_MSTS_MDN
SAMP_SRC_MIO_INP = SAMP_MIO_INP
SAMP_SRC_MIO_ORG = SAMP_MIO_ORG
SAMP_SRC_CONTROL_VOL = SAMP_CONTROL_VOL
SAMP_SRC_ENCODER_RAW = SAMP_ENCODER_RAW
SAMP_SRC_ERR_POS = SAMP_ERROR_POS
SAMP_SRC_COM_POS_F64 = SAMP_COM_POS_F64
SAMP_SRC_FBK_POS_F64 = SAMP_FBK_POS_F64
SAMP_SRC_CMD_VEL_F64 = SAMP_CMD_VEL_F64
SAMP_SRC_FBK_VEL_F64 = SAMP_FBK_VEL_F64
SAMP_SRC_CONTROL_VOL_F64 = SAMP_CONTROL_VOL_F64
SAMP_SRC_ERR_POS_F64 = SAMP_ERR_POS_F64

# =====================================================================================================
# Host interrupts [M §4.11], spec §2.23. The factor names are the manual's (IALM, IPEL, ...).
# ADLINK names neither the items nor the DI factors: INT_* names are vdevd choices.
# =====================================================================================================
INT_ITEM_AXIS0 = 0  # items 0-7: axis 0-7 (+ axis number)
INT_ITEM_SYSTEM = 8
INT_ITEM_DI_RISING = 9  # factor n = IDIRn
INT_ITEM_DI_FALLING = 10  # factor n = IDIFn
INT_ITEM_COUNT = 11
INT_FACTOR_COUNT = 32
#: APS_set_int_factor's interrupt number = board x INT_NO_PER_BOARD + item x 32 + factor (spec §2.23
#: ASSUMPTION)
INT_NO_PER_BOARD = INT_ITEM_COUNT * INT_FACTOR_COUNT  # vdevd choice (352)
# axis factors (items 0-7) [M §4.11, L3355]
IALM = 0
IPEL = 1
IMEL = 2
IORG = 3
IEZ = 4
IINP = 5
#: the manual names both axis bit 6 and system bit 0 "IEMG"; the suffixes are vdevd's
IEMG_AXIS = 6
ICSTP = 8
IVM = 9
IACC = 10
IDEC = 11
IMDN = 12
IASTP = 13
ISPEL = 15
ISMEL = 16
IPRED = 18
IPOSTD = 19
# system factors (item 8) [M §4.11, L3391]
IEMG_SYS = 0
ILCF0 = 1  # linear comparator 0 finished
ILCF1 = 2
IFCF0 = 3  # FIFO (table) comparator 0 finished
IFCF1 = 4
IMOV = 5  # motion loop overload
IHOV = 6  # host / system loop overload
# DI factors (items 9, 10): bits 0-7 EDI1-8, bits 8-23 TTL inputs 0-15 [M §4.11]
INT_DI_EDI0 = 0
INT_DI_TTL0 = 8
INT_DI_COUNT = 24

# =====================================================================================================
# Device identification
# =====================================================================================================
# APS_get_card_name [X2] (spec Q16: 14 is assumed to be the AMP-204C/208C)
DEVICE_NAME_NULL = 0xFFFF
DEVICE_NAME_PCI_8258 = 9
DEVICE_NAME_AMP_82548 = 14
# APS_get_device_info Info_No [X5 get_version_info]; ADLINK names none: the names are vdevd choices
DEVICE_INFO_DRIVER = 0x10
DEVICE_INFO_FPGA = 0x21
DEVICE_INFO_PCB = 0x30
DEVICE_INFO_DSP_KERNEL = 0x40

# =====================================================================================================
# APS_start_gear modes / APS_get_gear_status [X5], spec §2.15; the names are vdevd choices
# =====================================================================================================
GEAR_DISABLE = 0
GEAR_STANDARD = 1
GEAR_GANTRY = 2

# =====================================================================================================
# Point table [X3], [M §4.9.6], spec §2.21
# =====================================================================================================
MAX_PT_DIM = 6  # [X3]
# array sizes of the type_def.h structures [X3]
MAXARC2 = 2  # PTA2CA / PTA2CE axes
MAXARC3 = 3  # PTA3CA / PTA3CE axes
MAXHEXLIX = 3  # PTHCA / PTHCE axes (ADLINK's spelling)
MAX_SAMPL_CH = 8  # SAMP_PARAM.sourceByCh channels
MAX_SAMPL_SRC = 2  # SAMP_PARAM.sourceByCh[ch]: [0] source, [1] axis
VAO_DATA_MAX_POINTS = 32  # VAO_DATA.mappingDataArr (vdevd name)
PT_TABLE_COUNT = 2  # vdevd name; 2 tables x 50 points (spec Q5)
PT_BUFFER_POINTS = 50  # vdevd name
# PTSTS.BitSts bits [X3], [M §4.9.6.2]; the names are vdevd choices
PTSTS_WORKING = 0x01
PTSTS_FULL = 0x02
PTSTS_EMPTY = 0x04

# =====================================================================================================
# Card limits (the numbers are the manual's; the names are vdevd choices)
# =====================================================================================================
MQ_DEPTH = 10  # continuous-PTP motion buffer per axis [M §4.6.4]
TRG_FIFO_HW = 255  # table-compare hardware FIFO [M §4.9.2.2.2]
TRG_FIFO_CTRL = 999  # table-compare controller buffer
