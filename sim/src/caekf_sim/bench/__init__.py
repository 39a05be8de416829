"""CAN HIL bench for caekf: drives the estimator (caekf-host or an MCU) over a python-can bus
with the frames of firmware/protocol/caekf.dbc and reads its estimates back.

Modules: e2e (CRC-8 and alive counter, CTRL_PARAM value encoding), codec (cantools + numpy
column codec), transport (python-can bus; SocketCAN fast path), bench (configuration, lockstep
and real-time runs, decoding), results (CSV, summary, figures, comparison with caekf-replay),
buslog (candump -L logs: write and replay), runner (the paper's experiments back to back).
"""
from .bench import Ack, Bench, BenchError, ConfigRefused, Decoded, RunRecord, StepInputs, latency_stats
from .codec import EXPERIMENTS, Codec

__all__ = ["Ack", "Bench", "BenchError", "Codec", "ConfigRefused", "Decoded", "EXPERIMENTS", "RunRecord",
           "StepInputs", "latency_stats"]
