"""Cross-check: the C codec (firmware/protocol, on the C that sim/src/caekf_sim/codegen.py generates from
caekf.dbc at build time) against cantools' reading of caekf.dbc.

Every frame layout, scaling, ID, E2E data ID and name table is compared by encoding the same values
on both sides (byte for byte) and decoding each side's payloads with the other."""
import math
import random
import struct
from decimal import Decimal

import pytest

from e2e_ref import crc8_sae_j1850, crc16_ccitt_false, e2e_crc, seal, seal_fd, to_mantissa_exp10

E2E = ("E2E_CRC", "E2E_COUNTER")
RNG_SEED = 20240611


def c_table(dump):
    rows = {}
    for line in dump.listing("info"):
        name, can_id, data_id, layout, direction, length, lsb = line.split()
        rows[name] = dict(can_id=int(can_id), data_id=int(data_id), layout=int(layout), dir=int(direction),
                          len=int(length), lsb=float(lsb))
    return rows


def value_signal(msg):
    sigs = [s for s in msg.signals if s.name not in E2E + ("STEP",)]
    assert len(sigs) == 1, msg.name
    return sigs[0]


def dbc_layout(db, msg):
    """The message's CaekfLayout attribute: (its index, as caekf_layout_t numbers it, and its name)."""
    index = int(msg.dbc.attributes["CaekfLayout"].value)
    return index, db.dbc.attribute_definitions["CaekfLayout"].choices[index]


def encode(db, name, values, scaling=True):
    return db.encode_message(name, {"E2E_CRC": 0, "E2E_COUNTER": 0, **values}, scaling=scaling, strict=True).hex()


def c_hex(line):
    status, payload = line.split()
    return int(status), payload


# --- the message table -------------------------------------------------------------------------

def test_every_dbc_message_is_in_the_c_table_and_back(db, dump):
    table = c_table(dump)
    assert sorted(table) == sorted(m.name for m in db.messages)


def test_ids_data_ids_dlc_direction_layout_and_lsb_match(db, dump):
    table = c_table(dump)
    data_ids = set()
    for msg in db.messages:
        row = table[msg.name]
        assert row["can_id"] == msg.frame_id and not msg.is_extended_frame, msg.name
        assert msg.length == row["len"] and msg.is_fd == (row["len"] > 8), msg.name
        assert msg.is_fd or msg.length == 8, msg.name
        assert row["data_id"] == msg.dbc.attributes["E2E_DataID"].value, msg.name
        data_ids.add(row["data_id"])
        assert row["dir"] == (0 if msg.senders == ["BENCH"] else 1), msg.name
        index, layout = dbc_layout(db, msg)
        assert row["layout"] == index, msg.name
        if layout in ("INT36", "FLOAT32"):  # the generic value codec's frames: STEP and one value
            sig = value_signal(msg)
            want = (28, 36, True, 0, False) if layout == "INT36" else (32, 32, True, 0, True)
            assert (sig.start, sig.length, sig.is_signed, sig.offset, sig.is_float) == want, msg.name
            assert (msg.get_signal_by_name("STEP").start, msg.get_signal_by_name("STEP").length) == (12, 16)
        assert row["lsb"] == (value_signal(msg).scale if layout == "INT36" else 0.0), msg.name
    assert len(data_ids) == len(db.messages), "E2E data IDs must be unique"


def test_every_frame_starts_with_crc_and_counter(db):
    for msg in db.messages:
        crc, counter = msg.get_signal_by_name("E2E_CRC"), msg.get_signal_by_name("E2E_COUNTER")
        width = 16 if msg.is_fd else 8  # CAN FD frames: CRC-16 (profile-5 style)
        assert (crc.start, crc.length, crc.byte_order) == (0, width, "little_endian"), msg.name
        assert (counter.start, counter.length) == (width, 4), msg.name
        assert all(s.byte_order == "little_endian" for s in msg.signals)


def test_every_signal_has_a_comment_and_values_state_their_resolution(db):
    for msg in db.messages:
        assert msg.comment, msg.name
        for sig in msg.signals:
            assert sig.comment, f"{msg.name}.{sig.name}"
            if sig.is_float or sig.length == 36:
                assert "LSB" in sig.comment or "float32" in sig.comment, f"{msg.name}.{sig.name}"


# --- name tables -------------------------------------------------------------------------------

def test_param_value_table_is_the_schema_and_covers_the_signal(db):
    """The PARAM_ID value table is generated from the settings schema (codegen.py dbc --write)."""
    from caekf_sim.schema import codegen

    params = db.get_message_by_name("CTRL_PARAM").get_signal_by_name("PARAM_ID")
    schema = codegen.load()
    keys = [k for s in schema.wire for k in s.keys]
    assert [str(params.choices[i]) for i in sorted(params.choices)] == keys
    assert sorted(params.choices) == list(range(len(keys)))
    assert max(params.choices) == params.maximum


def test_counter_names_match_health_pages(db, dump):
    health = db.get_message_by_name("EST_HEALTH")
    by_page = sorted((s.multiplexer_ids[0], s.start, s.name) for s in health.signals if s.multiplexer_ids)
    assert [name for _, _, name in by_page] == dump.listing("names counter")
    assert health.get_signal_by_name("PAGE").maximum == len(by_page) // 2 - 1


# --- CRC and E2E -------------------------------------------------------------------------------

def test_crc_check_value():
    assert crc8_sae_j1850(b"123456789") == 0x4B


def test_crc_matches_reference_for_random_data(dump):
    rng = random.Random(RNG_SEED)
    data = [bytes(rng.randrange(256) for _ in range(rng.randrange(1, 20))) for _ in range(200)]
    out = dump.run(["crc 313233343536373839"] + [f"crc {d.hex()}" for d in data])
    assert out[0] == "0 4b"
    assert out[1:] == [f"0 {crc8_sae_j1850(d):02x}" for d in data]


def test_seal_matches_reference_for_every_message(db, dump):
    rng = random.Random(RNG_SEED + 1)
    cmds, expected = [], []
    for msg in db.messages:
        data_id = msg.dbc.attributes["E2E_DataID"].value
        for _ in range(20):
            payload = bytes(rng.randrange(256) for _ in range(msg.length))
            counter = rng.randrange(16)
            if msg.is_fd:  # CRC-16 over the whole length
                cmds.append(f"seal_fd {msg.name} {counter} {payload.hex()}")
                expected.append(f"0 {seal_fd(data_id, counter, payload).hex()}")
            else:
                cmds.append(f"seal {msg.name} {counter} {payload.hex()}")
                expected.append(f"0 {seal(data_id, counter, payload).hex()}")
    assert dump.run(cmds) == expected


def test_cantools_frame_sealed_by_reference_is_what_c_sends(db, dump):
    msg = db.get_message_by_name("BENCH_Y1")
    body = db.encode_message("BENCH_Y1", {"E2E_CRC": 0, "E2E_COUNTER": 9, "STEP": 1234, "Y1": 1.5e-3})
    sealed = seal(msg.dbc.attributes["E2E_DataID"].value, 9, body)
    status, c_body = c_hex(dump.one(f"enc_value BENCH_Y1 1234 {(1.5e-3).hex()}"))
    assert status == 0
    assert dump.one(f"seal BENCH_Y1 9 {c_body}") == f"0 {sealed.hex()}"
    assert db.decode_message(msg.frame_id, sealed)["E2E_CRC"] == e2e_crc(msg.dbc.attributes["E2E_DataID"].value, sealed)


# --- value frames (INT36, FLOAT32) --------------------------------------------------------------

def int36_values(sig, rng):
    lsb, max_raw = sig.scale, 2 ** 35 - 1
    ks = [0, 1, -1, 2, -2, 3, 1000, -1000, max_raw, -max_raw - 1, max_raw - 1, -max_raw]
    ks += [rng.randrange(-max_raw - 1, max_raw + 1) for _ in range(300)]
    values = [k * lsb for k in ks]
    # exact ties k + 0.5 after the division: both sides must round half to even
    ties = [k * lsb + 0.5 * lsb for k in range(-2000, 2000) if (k * lsb + 0.5 * lsb) / lsb == k + 0.5]
    assert len(ties) > 50
    values += ties
    values += [rng.uniform(sig.minimum, sig.maximum) for _ in range(300)]
    values += [rng.uniform(-1e-3, 1e-3) * 10 ** -rng.randrange(0, 9) for _ in range(200)]
    return [v for v in values if sig.minimum <= v <= sig.maximum]


def float_values(rng):
    vals = [0.0, -0.0, 1.0, -1.0, 1e8, 7.5e7, -1e12, 1e17, 1.6e16, 3.4028234663852886e38, -3.4028234663852886e38,
            1e-45, -1.4e-45, 1.1754943508222875e-38, 2.6, -2.6, math.pi]
    vals += [rng.uniform(-1, 1) * 10 ** rng.uniform(-40, 38) for _ in range(400)]
    return vals


@pytest.mark.parametrize("kind", ["INT36", "FLOAT32"])
def test_value_frames_encode_identically(db, dump, kind):
    rng = random.Random(RNG_SEED + 2)
    cmds, expected = [], []
    for msg in db.messages:
        if dbc_layout(db, msg)[1] != kind:
            continue
        sig = value_signal(msg)
        values = int36_values(sig, rng) if kind == "INT36" else float_values(rng)
        for v in values:
            step = rng.randrange(65536)
            cmds.append(f"enc_value {msg.name} {step} {v.hex()}")
            expected.append(f"0 {encode(db, msg.name, {'STEP': step, sig.name: v})}")
    assert len(cmds) > 1000
    got = dump.run(cmds)
    mismatches = [(c, g, e) for c, g, e in zip(cmds, got, expected) if g != e]
    assert not mismatches, mismatches[:5]


@pytest.mark.parametrize("kind", ["INT36", "FLOAT32"])
def test_value_frames_decode_identically(db, dump, kind):
    rng = random.Random(RNG_SEED + 3)
    cmds, expected = [], []
    for msg in db.messages:
        if dbc_layout(db, msg)[1] != kind:
            continue
        sig = value_signal(msg)
        for _ in range(300):
            step = rng.randrange(65536)
            if kind == "INT36":
                raw = rng.randrange(-2 ** 35, 2 ** 35)
            else:
                raw = struct.unpack("<f", struct.pack("<I", rng.randrange(2 ** 32)))[0]
                if not math.isfinite(raw):
                    continue
            payload = encode(db, msg.name, {"STEP": step, sig.name: raw}, scaling=False)
            decoded = db.decode_message(msg.frame_id, bytes.fromhex(payload))
            cmds.append(f"dec_value {msg.name} {payload}")
            expected.append((0, step, float(decoded[sig.name])))
    got = [(int(s), int(k), float.fromhex(v)) for s, k, v in (line.split() for line in dump.run(cmds))]
    mismatches = [(c, g, e) for c, g, e in zip(cmds, got, expected) if g != e]
    assert not mismatches, mismatches[:5]


def test_non_finite_floats_are_rejected_by_the_c_decoder(db, dump):
    for bits in (0x7FC00000, 0xFFC00001, 0x7F800000, 0xFF800000):
        value = struct.unpack("<f", struct.pack("<I", bits))[0]
        payload = db.encode_message("BENCH_U", {"E2E_CRC": 0, "E2E_COUNTER": 0, "STEP": 7, "U": value},
                                    strict=False).hex()
        assert payload[8:] == struct.pack("<I", bits).hex()
        assert dump.one(f"dec_value BENCH_U {payload}").split()[0] == "-3"


def test_int36_out_of_range_saturates_at_the_dbc_limits(db, dump):
    sig = value_signal(db.get_message_by_name("BENCH_Y1"))
    for v, limit in ((1.0, sig.maximum), (-1.0, sig.minimum), (float("nan"), 0.0)):
        status, payload = c_hex(dump.one(f"enc_value BENCH_Y1 3 {v.hex()}"))
        assert status == 1
        assert payload == encode(db, "BENCH_Y1", {"STEP": 3, "Y1": limit})


def test_position_resolution_is_far_below_a_micrometre(db):
    """Diagnostics profile scaled signals; the production profile's BENCH_YP trades resolution for room
    (LSB 1e-9 m, +/-2.1 mm: the scenarios' positions stay within 1.4 mm) and its outputs are float32."""
    for msg in db.messages:
        for sig in msg.signals:
            if sig.is_float:
                continue
            if msg.name == "BENCH_YP":
                assert sig.unit != "m" or (sig.scale <= 1e-9 and sig.maximum >= 0.0020), sig.name
                continue
            if sig.unit == "m":
                assert sig.scale <= 1e-12 and sig.maximum >= 0.03, sig.name
            if sig.unit == "m/s":
                assert sig.scale <= 1e-10 and sig.maximum >= 3.0, sig.name


# --- control frames and EST_STEP ----------------------------------------------------------------

def roundtrip(db, dump, name, c_enc, c_dec, cases, fields):
    """Each case: C encode == cantools encode; cantools payload decoded by C gives the fields back."""
    enc_cmds = [f"{c_enc} " + " ".join(str(case[f]) for f in fields) for case in cases]
    payloads = [encode(db, name, case) for case in cases]
    assert dump.run(enc_cmds) == [f"0 {p}" for p in payloads]
    decoded = dump.run([f"{c_dec} {p}" for p in payloads])
    assert decoded == ["0 " + " ".join(str(case[f]) for f in fields) for case in cases]


def test_step_frame(db, dump):
    rng = random.Random(RNG_SEED + 4)
    cases = [dict(STEP=rng.randrange(65536), FLAGS=rng.randrange(65536), NEWTON_ITERS=rng.randrange(256),
                  STEP_STATUS=rng.randrange(-128, 128)) for _ in range(200)]
    roundtrip(db, dump, "EST_STEP", "enc_step", "dec_step", cases, ["STEP", "FLAGS", "NEWTON_ITERS", "STEP_STATUS"])


# --- production profile frames: C (generated pack/unpack + scaling) against cantools ------------

def _f32(rng):
    return struct.unpack("<f", struct.pack("<f", rng.uniform(-1e3, 1e3) * 10.0 ** rng.randrange(-12, 12)))[0]


def test_yp_frame(db, dump):
    rng = random.Random(RNG_SEED + 11)
    sig = db.get_message_by_name("BENCH_YP").get_signal_by_name("Y1")
    half = 1 << (sig.length - 1)
    lim = half * sig.scale
    cases = []
    for _ in range(300):
        raw1, raw4 = rng.randrange(-half, half), rng.randrange(-half, half)
        cases.append(dict(STEP=rng.randrange(256), Y1=raw1 * sig.scale, Y4=raw4 * sig.scale,
                          r1=rng.uniform(-lim, lim), r4=rng.uniform(-lim, lim)))
    # values on the LSB grid and arbitrary values: both sides round the same way
    enc = dump.run([f"enc_yp {c['STEP']} {c['Y1']!r} {c['Y4']!r}" for c in cases] +
                   [f"enc_yp {c['STEP']} {c['r1']!r} {c['r4']!r}" for c in cases])
    want = [f"0 {encode(db, 'BENCH_YP', dict(STEP=c['STEP'], Y1=c['Y1'], Y4=c['Y4']))}" for c in cases] + \
           [f"0 {encode(db, 'BENCH_YP', dict(STEP=c['STEP'], Y1=c['r1'], Y4=c['r4']))}" for c in cases]
    assert enc == want
    payloads = [w.split()[1] for w in want]
    for line, p in zip(dump.run([f"dec_yp {p}" for p in payloads]), payloads):
        st, step, y1, y4 = line.split()
        ref = db.decode_message("BENCH_YP", bytes.fromhex(p))
        assert (int(st), int(step), float.fromhex(y1), float.fromhex(y4)) == (0, ref["STEP"], ref["Y1"], ref["Y4"])
    # beyond the range: clipped to the DBC's ends and flagged
    st, payload = dump.one("enc_yp 1 0.5 -0.5").split()
    ref = db.decode_message("BENCH_YP", bytes.fromhex(payload))
    assert int(st) == 1 and (ref["Y1"], ref["Y4"]) == ((half - 1) * sig.scale, -half * sig.scale)


def test_prod_frame(db, dump):
    rng = random.Random(RNG_SEED + 12)
    prod = db.get_message_by_name("EST_PROD")
    step_mod, flags_mod = (1 << prod.get_signal_by_name(name).length for name in ("STEP", "FLAGS"))
    cases = [dict(STEP=rng.randrange(step_mod), FLAGS=rng.randrange(flags_mod), GAMMA=_f32(rng)) for _ in range(300)]
    enc = dump.run([f"enc_prod {c['STEP']} {c['FLAGS']} {c['GAMMA']!r}" for c in cases])
    assert enc == [f"0 {encode(db, 'EST_PROD', c)}" for c in cases]
    dec = dump.run([f"dec_prod {line.split()[1]}" for line in enc])
    got = [(int(a), int(b), int(c), float.fromhex(d)) for a, b, c, d in (line.split() for line in dec)]
    assert got == [(0, c["STEP"], c["FLAGS"], c["GAMMA"]) for c in cases]
    # flags above the signal's width are not part of EST_PROD: the C encoder drops them
    assert dump.one("enc_prod 1 65535 1.0").split()[1] == encode(db, "EST_PROD",
                                                                 dict(STEP=1, FLAGS=flags_mod - 1, GAMMA=1.0))


PAGE_SIGNALS = ("Q1", "Q2", "Q3", "Q4", "V1", "V2", "V3", "V4", "P_NORM", "P_GAMMA_GAMMA")


def test_page_frames(db, dump):
    rng = random.Random(RNG_SEED + 13)
    cmds, want, dec_want = [], [], []
    for _ in range(400):
        page, step = rng.randrange(11), rng.randrange(65536)
        if page < 10:
            v = _f32(rng)
            cmds.append(f"enc_page {page} {step} {v!r} 0 0 0")
            want.append(encode(db, "EST_PAGE", {"PAGE": page, "STEP": step, PAGE_SIGNALS[page]: v}))
            dec_want.append((0, page, step, v, 0, 0, 0))
        else:
            fl, it, st = rng.randrange(65536), rng.randrange(256), rng.randrange(-128, 128)
            cmds.append(f"enc_page 10 {step} 0 {fl} {it} {st}")
            want.append(encode(db, "EST_PAGE", {"PAGE": 10, "STEP": step, "FLAGS": fl, "NEWTON_ITERS": it,
                                                "STEP_STATUS": st}))
            dec_want.append((0, 10, step, 0.0, fl, it, st))
    assert dump.run(cmds) == [f"0 {w}" for w in want]
    got = [(int(a), int(b), int(c), float.fromhex(d), int(e), int(f), int(g))
           for a, b, c, d, e, f, g in (line.split() for line in dump.run([f"dec_page {w}" for w in want]))]
    assert got == dec_want
    assert dump.one("enc_page 11 1 0 0 0 0").split()[0] == "-4"  # CAEKF_PROTO_ERR_RANGE


def test_reset_frame(db, dump):
    rng = random.Random(RNG_SEED + 5)
    cases = [dict(N_PARAMS=rng.randrange(256), TOKEN=rng.randrange(256)) for _ in range(100)]
    roundtrip(db, dump, "CTRL_RESET", "enc_reset", "dec_reset", cases, ["N_PARAMS", "TOKEN"])


def test_param_frame(db, dump):
    rng = random.Random(RNG_SEED + 6)
    n_ids = db.get_message_by_name("CTRL_PARAM").get_signal_by_name("PARAM_ID").maximum + 1
    cases = [dict(PARAM_ID=rng.randrange(n_ids), PARAM_EXP10=rng.randrange(-22, 23),
                  PARAM_MANTISSA=rng.randrange(-2 ** 37, 2 ** 37)) for _ in range(200)]
    cases += [dict(PARAM_ID=36, PARAM_EXP10=-22, PARAM_MANTISSA=-2 ** 37),
              dict(PARAM_ID=0, PARAM_EXP10=22, PARAM_MANTISSA=2 ** 37 - 1)]
    roundtrip(db, dump, "CTRL_PARAM", "enc_param", "dec_param", cases, ["PARAM_ID", "PARAM_EXP10", "PARAM_MANTISSA"])


def test_status_req_ack_and_health_frames(db, dump):
    rng = random.Random(RNG_SEED + 7)
    roundtrip(db, dump, "CTRL_STATUS_REQ", "enc_status_req", "dec_status_req",
              [dict(TOKEN=t) for t in range(0, 256, 7)], ["TOKEN"])
    acks = [dict(TOKEN=rng.randrange(256), ACK_STATUS=rng.choice([1, 0, -1, -2, -4, -5, -6]),
                 BAD_PARAM=rng.randrange(256), N_PARAMS_RX=rng.randrange(256),
                 STATE=rng.randrange(256)) for _ in range(100)]
    roundtrip(db, dump, "EST_ACK", "enc_ack", "dec_ack", acks,
              ["TOKEN", "ACK_STATUS", "BAD_PARAM", "N_PARAMS_RX", "STATE"])
    health = db.get_message_by_name("EST_HEALTH")
    pages = {}
    for s in health.signals:
        if s.multiplexer_ids:
            pages.setdefault(s.multiplexer_ids[0], []).append(s)
    cases, c_cases = [], []
    for page, sigs in sorted(pages.items()):
        a, b = sorted(sigs, key=lambda s: s.start)
        for _ in range(10):
            va, vb = rng.randrange(2 ** 24), rng.randrange(2 ** 24)
            cases.append({"PAGE": page, a.name: va, b.name: vb})
            c_cases.append(dict(PAGE=page, A=va, B=vb))
    assert dump.run([f"enc_health {c['PAGE']} {c['A']} {c['B']}" for c in c_cases]) == \
        [f"0 {encode(db, 'EST_HEALTH', case)}" for case in cases]
    assert dump.run([f"dec_health {encode(db, 'EST_HEALTH', case)}" for case in cases]) == \
        [f"0 {c['PAGE']} {c['A']} {c['B']}" for c in c_cases]


# --- decimal parameter values --------------------------------------------------------------------

SCENARIO_VALUES = [1.0, 2.0e3, 1.0e4, 5.0, 1.0e-3, 7.5e7, 1.0e-6, 1.0e-5, 2.5e7, 1.0e-9, 1.0e-7, 1.0e6, 1.0e-7,
                   1.0e6, 1000.0, 1e-10, 1e-12, 0.0, 20.0, 3.141592653589793]


def test_param_values_arrive_as_the_exact_double(dump):
    rng = random.Random(RNG_SEED + 8)
    values = SCENARIO_VALUES + [round(rng.uniform(-1, 1), rng.randrange(1, 10)) * 10 ** rng.randrange(-15, 12)
                                for _ in range(500)]
    cmds, expected = [], []
    for v in values:
        mant, exp = to_mantissa_exp10(v)
        shortest = Decimal(repr(v)).normalize().as_tuple().digits
        if abs(exp) > 22:
            continue
        cmds.append(f"param_value 0 {exp} {mant}")
        exact = float(f"{mant}e{exp}")  # Python's correctly rounded decimal conversion
        expected.append((0, exact))
        if len(shortest) <= 11:
            assert exact == v, "the bench's decimal form must reproduce the double exactly"
    got = [(int(s), float.fromhex(x)) for s, x in (line.split() for line in dump.run(cmds))]
    assert got == expected


def test_param_exponent_beyond_exact_range_is_refused(dump):
    assert dump.one("param_value 0 23 1").split()[0] == "-3"
    assert dump.one("param_value 0 -23 1").split()[0] == "-3"


def test_generator_refuses_a_value_frame_the_codec_cannot_read(tmp_path):
    """The generic value codec assumes STEP 12|16 and the value at 28|36 (INT36) or 32|32 float (FLOAT32): a
    DBC whose message breaks that fails the build's generation with a message naming it."""
    from caekf_sim import codegen

    text = codegen.default_dbc().read_text(encoding="utf-8")
    assert codegen.main([str(tmp_path / "ok")]) == 0
    for old, new, name in ((" SG_ Y1 : 28|36@1- (1e-12,0)", " SG_ Y1 : 28|32@1- (1e-12,0)", "BENCH_Y1"),
                           (' BA_ "CaekfLayout" BO_ 256 6;', ' BA_ "CaekfLayout" BO_ 256 5;', "BENCH_U")):
        assert old.strip() in text, old
        bad = tmp_path / f"{name}.dbc"
        bad.write_text(text.replace(old.strip(), new.strip(), 1), encoding="utf-8")
        with pytest.raises(ValueError, match=name):
            codegen.generate(bad)


# --- CAN FD profile frames: C (generated pack/unpack + scaling, CRC-16 seal) against cantools --------------

def test_crc16_check_value_and_fd_seal(db, dump):
    assert crc16_ccitt_false(b"123456789") == 0x29B1
    assert dump.one("crc16 " + b"123456789".hex()) == "0 29b1"
    rng = random.Random(RNG_SEED + 21)
    for name in ("BENCH_FD", "EST_FD"):
        msg = db.get_message_by_name(name)
        for counter in (0, 7, 15):
            body = bytes(rng.randrange(256) for _ in range(msg.length))
            want = seal_fd(msg.dbc.attributes["E2E_DataID"].value, counter, body)
            assert dump.one(f"seal_fd {name} {counter} {body.hex()}") == f"0 {want.hex()}"


def test_fd_in_frame(db, dump):
    rng = random.Random(RNG_SEED + 22)
    sig = db.get_message_by_name("BENCH_FD").get_signal_by_name("Y1")
    lim = (1 << (sig.length - 1)) * sig.scale
    cases = [dict(STEP=rng.randrange(65536), U=_f32(rng), Y1=rng.uniform(-lim, lim), Y4=rng.uniform(-lim, lim))
             for _ in range(300)]
    enc = dump.run([f"enc_fd_in {c['STEP']} {c['U']!r} {c['Y1']!r} {c['Y4']!r}" for c in cases])
    assert enc == [f"0 {encode(db, 'BENCH_FD', c)}" for c in cases]
    for line, c in zip(dump.run([f"dec_fd_in {encode(db, 'BENCH_FD', c)}" for c in cases]), cases):
        st, step, u, y1, y4 = line.split()
        ref = db.decode_message("BENCH_FD", bytes.fromhex(encode(db, "BENCH_FD", c)))
        assert (int(st), int(step), float.fromhex(u), float.fromhex(y1), float.fromhex(y4)) == \
            (0, ref["STEP"], ref["U"], ref["Y1"], ref["Y4"])
    # a non-finite U is refused
    nan = encode(db, "BENCH_FD", dict(STEP=1, U=0.0, Y1=0.0, Y4=0.0))
    nan = nan[:10] + struct.pack("<f", math.nan).hex() + nan[18:]
    assert dump.one(f"dec_fd_in {nan}").split()[0] == "-3"


def test_fd_out_frame(db, dump):
    rng = random.Random(RNG_SEED + 23)
    names = ("Q1", "Q2", "Q3", "Q4", "V1", "V2", "V3", "V4", "GAMMA")
    msg = db.get_message_by_name("EST_FD")
    cases = []
    for _ in range(200):
        c = {n: (rng.uniform(-0.03, 0.03) if n[0] == "Q" else rng.uniform(-3.0, 3.0) if n[0] == "V" else _f32(rng))
             for n in names}
        c.update(STEP=rng.randrange(65536), P_NORM=_f32(rng), P_GAMMA_GAMMA=_f32(rng), FLAGS=rng.randrange(65536),
                 NEWTON_ITERS=rng.randrange(256), STEP_STATUS=rng.randrange(-128, 128))
        cases.append(c)
    cmd = [f"enc_fd_out {c['STEP']} " + " ".join(repr(c[n]) for n in names)
           + f" {c['P_NORM']!r} {c['P_GAMMA_GAMMA']!r} {c['FLAGS']} {c['NEWTON_ITERS']} {c['STEP_STATUS']}"
           for c in cases]
    assert dump.run(cmd) == [f"0 {encode(db, 'EST_FD', c)}" for c in cases]
    for line, c in zip(dump.run([f"dec_fd_out {encode(db, 'EST_FD', c)}" for c in cases]), cases):
        f = line.split()
        ref = db.decode_message("EST_FD", bytes.fromhex(encode(db, "EST_FD", c)))
        assert int(f[0]) == 0 and int(f[1]) == ref["STEP"]
        assert [float.fromhex(v) for v in f[2:13]] == [ref[n] for n in names + ("P_NORM", "P_GAMMA_GAMMA")]
        assert (int(f[13]), int(f[14]), int(f[15])) == (ref["FLAGS"], ref["NEWTON_ITERS"], ref["STEP_STATUS"])
    assert msg.length == 64


def test_named_bits_come_from_the_dbc_and_are_checked(tmp_path):
    """EST_STEP.FLAGS' application bits and EST_ACK.STATE's bits are the DBC's CaekfBits attribute: the generated
    header defines them, and a bit given twice or beyond its signal fails the generation naming the signal."""
    from caekf_sim import codegen

    text = codegen.default_dbc().read_text(encoding="utf-8")
    header = codegen.generate()[codegen.FRAMES_HEADER]
    db = codegen.load()
    for msg, sig, prefix in (("EST_STEP", "FLAGS", "CAEKF_STEP_FLAGS_"), ("EST_ACK", "STATE", "CAEKF_ACK_STATE_")):
        bits = codegen.named_bits(db.get_message_by_name(msg).get_signal_by_name(sig))
        assert bits
        for name, bit in bits.items():
            assert f"#define {prefix}{name} (1u << {bit})" in header
    old = 'BA_ "CaekfBits" SG_ 395 FLAGS "13 SATURATED,14 STEP_GAP,15 PNORM_UNAVAILABLE";'
    assert old in text
    for new in (old.replace("14 STEP_GAP", "13 STEP_GAP"), old.replace("15 PNORM", "16 PNORM")):
        bad = tmp_path / "bad.dbc"
        bad.write_text(text.replace(old, new, 1), encoding="utf-8")
        with pytest.raises(ValueError, match="FLAGS"):
            codegen.generate(bad)
