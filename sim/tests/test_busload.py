"""Bus-load arithmetic: the vectorised exact frame length against a plain bit-by-bit reference, the
worst case as its upper bound, and the DBC's diagnostics profile."""
import numpy as np

from caekf_sim.bench.busload import (classic_bits_exact, classic_bits_worst, dbc_profile_load, fd_time_worst,
                                     step_messages)
from caekf_sim.bench.codec import Codec


def _reference_bits(fid: int, data: bytes) -> int:
    """One classic 11-bit data frame, built bit by bit: SOF, ID, RTR, IDE, r0, DLC, data, CRC-15, stuffing
    over all of those, then 10 fixed bits (CRC delimiter, ACK, EOF) and 3 of interframe space."""
    bits = [0] + [(fid >> (10 - j)) & 1 for j in range(11)] + [0, 0, 0]
    bits += [(len(data) >> (3 - j)) & 1 for j in range(4)]
    for b in data:
        bits += [(b >> (7 - j)) & 1 for j in range(8)]
    crc = 0
    for b in bits:
        top = b ^ ((crc >> 14) & 1)
        crc = (crc << 1) & 0x7FFF
        if top:
            crc ^= 0x4599
    bits += [(crc >> (14 - j)) & 1 for j in range(15)]
    wire = []
    for b in bits:
        wire.append(b)
        if len(wire) >= 5 and len(set(wire[-5:])) == 1:
            wire.append(1 - b)  # the stuff bit; it counts in the next run
    return len(wire) + 13


def test_exact_length_equals_bit_by_bit_reference():
    rng = np.random.default_rng(7)
    k = 600
    ids = rng.integers(0, 0x800, k)
    dlc = rng.integers(0, 9, k)
    data = rng.integers(0, 256, (k, 8)).astype(np.uint8)
    data[:100] = 0  # long runs: the most stuffing
    data[100:200] = 0xFF
    ids[:50] = 0
    for i in range(k):
        data[i, dlc[i]:] = 0
    got = classic_bits_exact(ids, dlc, data)
    ref = np.array([_reference_bits(int(ids[i]), bytes(data[i, :dlc[i]])) for i in range(k)])
    assert np.array_equal(got, ref)
    assert np.all(got <= classic_bits_worst(dlc))
    assert np.all(got >= 34 + 8 * dlc + 13)


def test_diagnostics_profile_from_the_dbc():
    codec = Codec()
    names = step_messages(codec.db)
    assert set(names) >= {"BENCH_U", "BENCH_Y1", "BENCH_Y4", "EST_STEP"}
    load = dbc_profile_load(codec.db, names, 1000.0, 1e6)
    worst8 = float(classic_bits_worst(8)) / 1e6
    assert load.frames_per_step == len(names)
    assert np.isclose(load.seconds_per_step, len(names) * worst8)


def test_fd_frame_longer_with_more_data_and_shorter_with_faster_data_phase():
    assert fd_time_worst(64, 1e6, 5e6) > fd_time_worst(20, 1e6, 5e6) > fd_time_worst(8, 1e6, 5e6)
    assert fd_time_worst(64, 1e6, 5e6) < fd_time_worst(64, 1e6, 2e6)
    assert fd_time_worst(13, 1e6, 5e6) == fd_time_worst(16, 1e6, 5e6)  # padded to the next FD length


def test_fd_profile_from_the_dbc_fits_its_budget():
    """BENCH_FD (20 bytes) + EST_FD (64 bytes) at 1 Mbit/s arbitration, 5 Mbit/s data: 81.6 + 169.6 us worst case,
    + 12 EST_HEALTH/s: 25.3 % at 1 kHz (target <= 30 %)."""
    from caekf_sim.bench.profiles import DATA_BITRATE, FD

    codec = Codec()
    assert codec.db.get_message_by_name("BENCH_FD").is_fd and codec.db.get_message_by_name("EST_FD").length == 64
    assert np.isclose(fd_time_worst(20, 1e6, 5e6), 81.6e-6) and np.isclose(fd_time_worst(64, 1e6, 5e6), 169.6e-6)
    load = dbc_profile_load(codec.db, list(FD.per_step), 1000.0, 1e6, DATA_BITRATE, "fd", FD.per_step)
    assert np.isclose(load.seconds_per_step, 81.6e-6 + 169.6e-6 + 0.012 * 135e-6)
    assert load.load <= 0.30
