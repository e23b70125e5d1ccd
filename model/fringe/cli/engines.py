"""The correction engines behind `fringe correct --engine`: float, the bit-exact model, the RTL in simulation."""

from ..dsp.calibration import Calibration
from ..engine.pipeline import run_float
from ..errors import FringeInputError
from ..hardware.corefiles import core_config, saved_core_fields
from ..io.dataio import Measurement
from ..result import Result


def streamable(name: str, cal: Calibration, cal_dir: str):
    """For the bit-exact model without the drift tracker and fringe_canceller: a function from one piece of the
    recording to its (angle_deg, status), bit-exact with one run over the whole recording
    (`fixed.core.CoreStream`); else None (the engine runs on the whole recording at once)."""
    from ..hardware.closed_loop import unsupported

    if name != "model" or unsupported(cal):
        return None
    from ..fixed.core import CoreStream, streams, to_adc_codes

    cfg = core_config(cal, cal_dir)
    if not streams(cfg):
        return None
    from ..hardware.tables import build_tables

    try:
        stream = CoreStream(build_tables(cal, cfg), cfg)
    except ValueError as e:
        raise FringeInputError(str(e), cal_dir) from None

    def step(m: Measurement):
        try:
            pos, status = stream.run(to_adc_codes(m.sin, cfg.adc_w, "sin"), to_adc_codes(m.cos, cfg.adc_w, "cos"),
                                     m.coarse)
        except ValueError as e:
            raise FringeInputError(str(e), m.path) from None
        return pos * (360.0 / cfg.rev), status

    return step


def run_engine(name: str, cal: Calibration, meas: Measurement, cal_dir: str) -> Result:
    if name == "float":
        saved_core_fields(cal, cal_dir)     # refuses a mixed folder, as the bit-exact engines do
        return run_float(cal, meas.sin, meas.cos, meas.coarse, meas.t_s)
    from ..hardware.closed_loop import unsupported
    from ..hardware.tables import run_model

    if unsupported(cal):
        raise FringeInputError("this calibration carries closed-loop corrections that the bit-exact core does not "
                               f"implement ({', '.join(unsupported(cal))}): use --engine float", cal_dir)
    cfg = core_config(cal, cal_dir)
    from ..hardware.tables import build_tables

    try:                       # a calibration the core cannot hold is the calibration's fault, not the data's
        tables = build_tables(cal, cfg)
    except ValueError as e:
        raise FringeInputError(str(e), cal_dir) from None
    try:
        if name == "model":
            return run_model(cal, cfg, meas.sin, meas.cos, meas.coarse, tables=tables)
    except ValueError as e:
        raise FringeInputError(str(e), meas.path) from None
    from ..hardware.rtlsim import RtlSimulationError, run_rtl_result

    try:
        return run_rtl_result(cal, cfg, meas.sin, meas.cos, meas.coarse, name)
    except ValueError as e:
        raise FringeInputError(str(e), meas.path) from None
    except RtlSimulationError as e:
        raise FringeInputError(f"the {name} simulation failed: {str(e).splitlines()[0]}", "--engine") from None
