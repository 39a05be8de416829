"""Reference (Python) side of the caekf E2E protection and parameter encoding, written from the DBC's
comments only. The bench in sim/ must do the same; these functions are what the cross-check trusts."""
from decimal import Decimal

CRC8_POLY = 0x1D


def crc8_sae_j1850(data: bytes) -> int:
    """CRC-8/SAE-J1850: poly 0x1D, init 0xFF, xorout 0xFF, not reflected."""
    crc = 0xFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ CRC8_POLY) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ 0xFF


def e2e_crc(data_id: int, payload: bytes) -> int:
    """CRC over data ID low byte, high byte, then payload bytes 1..7 (byte 0 is the CRC itself)."""
    return crc8_sae_j1850(bytes([data_id & 0xFF, data_id >> 8]) + bytes(payload[1:8]))


def seal(data_id: int, counter: int, payload: bytes) -> bytes:
    """Writes the alive counter (bits 8..11) and the CRC (byte 0) into an 8-byte payload."""
    b = bytearray(payload)
    b[1] = (b[1] & 0xF0) | (counter & 0x0F)
    b[0] = e2e_crc(data_id, b)
    return bytes(b)


def crc16_ccitt_false(data: bytes) -> int:
    """CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, xorout 0, not reflected."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def seal_fd(data_id: int, counter: int, payload: bytes) -> bytes:
    """CAN FD frames: the alive counter in bits 16..19, then the CRC-16 over data ID low byte, high byte and
    payload bytes 2.. into bytes 0..1 (little-endian)."""
    b = bytearray(payload)
    b[2] = (b[2] & 0xF0) | (counter & 0x0F)
    crc = crc16_ccitt_false(bytes([data_id & 0xFF, data_id >> 8]) + bytes(b[2:]))
    b[0], b[1] = crc & 0xFF, crc >> 8
    return bytes(b)


def to_mantissa_exp10(value: float, max_digits: int = 11) -> tuple[int, int]:
    """Shortest decimal form of a float as (mantissa, exp10), value = mantissa * 10**exp10.
    Values needing more than max_digits significant digits are rounded to max_digits."""
    d = Decimal(repr(float(value)))
    if d == 0:
        return 0, 0
    d = d.normalize()
    sign, digits, exp = d.as_tuple()
    if len(digits) > max_digits:
        d = Decimal(d).quantize(Decimal(1).scaleb(exp + len(digits) - max_digits)).normalize()
        sign, digits, exp = d.as_tuple()
    mant = int("".join(map(str, digits)))
    return (-mant if sign else mant), exp
