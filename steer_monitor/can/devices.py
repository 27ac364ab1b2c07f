"""Devices on an NMEA 2000 bus: who holds which source address, from ISO address claims.

A device announces its 64-bit NAME (ISO 11783-5, PGN 60928, 8 bytes little-endian) with
the source address it takes. After an address conflict the device with the lower NAME
keeps the address and the other claims another one (or, from address 254, says it cannot
claim any), so a device is known by its NAME, not its address. Pure: no python-can here.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ['ADDRESS_CLAIM_PGN', 'CANNOT_CLAIM', 'DeviceName', 'DeviceTable', 'format_name', 'parse_name']

ADDRESS_CLAIM_PGN = 60928
#: the source address of a "cannot claim an address" message
CANNOT_CLAIM = 254


def parse_name(text: str) -> int:
    """A NAME written as up to 16 hex digits (``0x`` optional; as :func:`format_name` writes
    it). Raises ValueError naming what is wrong."""
    t = text.strip()
    digits = t[2:] if t.lower().startswith('0x') else t
    if not digits or len(digits) > 16 or any(c not in '0123456789abcdefABCDEF' for c in digits):
        msg = f'expected a device NAME as 16 hex digits (as discover prints it), got {text!r}'
        raise ValueError(msg)
    return int(digits, 16)


def format_name(name: int) -> str:
    """A NAME as 16 hex digits, most significant first."""
    return f'{name:016X}'


@dataclass(frozen=True)
class DeviceName:
    """The fields of a 64-bit NAME (ISO 11783-5; bit 0 is bit 0 of the first data byte)."""

    name: int

    @classmethod
    def from_data(cls, data: bytes) -> DeviceName:
        return cls(int.from_bytes(bytes(data[:8]), 'little'))

    def _bits(self, start: int, length: int) -> int:
        return (self.name >> start) & ((1 << length) - 1)

    @property
    def unique_number(self) -> int:
        return self._bits(0, 21)

    @property
    def manufacturer_code(self) -> int:
        return self._bits(21, 11)

    @property
    def device_instance(self) -> int:
        return self._bits(32, 8)

    @property
    def device_function(self) -> int:
        return self._bits(40, 8)

    @property
    def device_class(self) -> int:
        return self._bits(49, 7)

    @property
    def system_instance(self) -> int:
        return self._bits(56, 4)

    @property
    def industry_group(self) -> int:
        return self._bits(60, 3)

    @property
    def arbitrary_address_capable(self) -> bool:
        return bool(self._bits(63, 1))

    def fields(self) -> dict[str, int | bool | str]:
        return {'name_hex': format_name(self.name), 'unique_number': self.unique_number,
                'manufacturer_code': self.manufacturer_code, 'device_instance': self.device_instance,
                'device_function': self.device_function, 'device_class': self.device_class,
                'system_instance': self.system_instance, 'industry_group': self.industry_group,
                'arbitrary_address_capable': self.arbitrary_address_capable}


class DeviceTable:
    """Which NAME holds which source address, as the claims so far say.

    ``seed`` states where a device is before any claim of it is seen (from the signal map:
    logs seldom begin with the claims made at power-up); a claim overrides it.
    """

    def __init__(self) -> None:
        self._name_at: dict[int, int] = {}      # address -> NAME
        self._address_of: dict[int, int] = {}   # NAME -> address

    def seed(self, address: int, name: int) -> None:
        if name not in self._address_of and address not in self._name_at:
            self.claim(address, name)

    def claim(self, address: int, name: int) -> None:
        """``name`` claimed ``address`` (CANNOT_CLAIM: it holds none now)."""
        old = self._address_of.pop(name, None)
        if old is not None:
            del self._name_at[old]
        if address == CANNOT_CLAIM:
            return
        loser = self._name_at.get(address)
        if loser is not None:
            del self._address_of[loser]
        self._name_at[address] = name
        self._address_of[name] = address

    def name_at(self, address: int) -> int | None:
        return self._name_at.get(address)

    def address_of(self, name: int) -> int | None:
        return self._address_of.get(name)
