"""The flow application: first-order surrogates of a viscous delivery system.

Records of pressure drop and flow rate (:mod:`~pumpid.flow.records`), the surrogates
(:mod:`~pumpid.flow.surrogates`), their fits on the shared engine (:mod:`~pumpid.flow.fit`),
the reference pipe-flow simulator (:mod:`~pumpid.flow.pipeflow`; the pipe, the fluid and
the closed-form flows in :mod:`~pumpid.flow.pipe`), the step study
(:mod:`~pumpid.flow.study`) and their reports (:mod:`~pumpid.flow.report`).
"""

from .fit import fit_flow, fit_flow_records, simulate_flow_record, simulate_surrogate
from .pipeflow import PipeNumerics
from .records import (
    FLOW_UNITS,
    PRESSURE_UNITS,
    FlowRecord,
    convert_flow,
    convert_pressure,
    flow_record,
    read_flow_record,
)
from .study import StepStudy, step_response_study

__all__ = [
    "FLOW_UNITS",
    "PRESSURE_UNITS",
    "FlowRecord",
    "PipeNumerics",
    "StepStudy",
    "convert_flow",
    "convert_pressure",
    "fit_flow",
    "fit_flow_records",
    "flow_record",
    "read_flow_record",
    "simulate_flow_record",
    "simulate_surrogate",
    "step_response_study",
]
