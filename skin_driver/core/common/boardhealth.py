"""
What a board says of its health in its information frame, by name (docs/firmware.md, "Faults").

The firmware appends to the six identity keys (core.common.boardinfo) why it last reset
(``reset``), the fault that stopped it before that reset (``fault``), its clock's source
(``clock``) and counters of the faults it recovered from since (``drop`` from a version-1 board
or ``flagged`` from a version-2 one, ``adc_ovr``, ``adc_to``, ``link_to``, ``hse_lost``,
``mux``). A board that sends none of them (the simulator, an older firmware) has no health to
show; a value this host does not know is shown as sent.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ['BoardHealth', 'COUNTERS', 'HEALTH_KEYS', 'RESET_CAUSES']

# RCC_CSR's reset flags as the firmware names them.
RESET_CAUSES = {
    'por': 'power-on', 'pin': 'reset pin (NRST, the reset button or the ST-LINK)',
    'iwdg': 'independent watchdog (the firmware hung)', 'wwdg': 'window watchdog',
    'sw': 'software reset (after a fault, when one is named)', 'lpwr': 'low-power reset',
    'bor': 'brown-out (the supply dropped)', 'unknown': 'unknown (no reset flags: emulated board)'}
# Resets a person should look into: the board did not restart because it was told to.
_ALARMING_RESETS = ('iwdg', 'wwdg', 'bor', 'lpwr')
FAULTS = {
    'pll': 'the PLL did not lock', 'overdrive': "the regulator's over-drive did not start",
    'flash': 'the flash did not take its wait states',
    'switch': 'the system clock did not switch to the PLL', 'hardfault': 'a hard fault',
    'memmanage': 'a memory management fault', 'busfault': 'a bus fault',
    'usagefault': 'a usage fault', 'nmi': 'an unexpected NMI', 'irq': 'an unexpected interrupt'}
CLOCKS = {'hse': 'external 8 MHz (the ST-LINK MCO)',
          'hsi': 'internal 16 MHz (the HSE was absent at start or failed since)'}
# (key, name) of each fault counter, in the order the board sends them.
COUNTERS = (
    ('drop', 'frames dropped by the board (a row failed to sample)'),
    ('flagged', 'frames sent with a row the board failed to sample marked'),
    ('adc_ovr', 'ADC overruns'), ('adc_to', 'ADC timeouts'),
    ('link_to', 'link timeouts (a transfer to the host did not end)'),
    ('hse_lost', 'external clock failures'),
    ('mux', 'scans dropped by the board with every row of a layer alike while pressed '
            '(row mux stuck?)'))
HEALTH_KEYS = ('reset', 'fault', 'clock', *(key for key, _ in COUNTERS))


def _named(table: dict, value: str) -> str:
    return f'{value}: {table[value]}' if value in table else value


def _count(value: str):
    return int(value) if value.isdigit() else None


@dataclass(frozen=True)
class BoardHealth:
    """The health keys of one information frame: each the text sent, or '' when not sent."""

    reset: str = ''
    fault: str = ''
    clock: str = ''
    counters: tuple = ()  # (key, value as sent) of the counters sent, in the order sent

    @classmethod
    def of(cls, info) -> BoardHealth | None:
        """Return the health in ``info`` (a BoardInfo or None); None when it sends none."""
        extra = dict(info.extra) if info is not None else {}
        if not any(key in extra for key in HEALTH_KEYS):
            return None
        return cls(extra.get('reset', ''), extra.get('fault', ''), extra.get('clock', ''),
                   tuple((key, extra[key]) for key, _ in COUNTERS if key in extra))

    def count(self, key: str):
        """Return the counter ``key`` as an int, or None when not sent or not a number."""
        return _count(dict(self.counters).get(key, ''))

    def values(self) -> dict:
        """Return the health as diagnostic values, each under its name."""
        values = {'board reset cause': _named(RESET_CAUSES, self.reset) or 'not sent',
                  'board fault before the reset': _named(FAULTS, self.fault) or 'none',
                  'board clock': _named(CLOCKS, self.clock) or 'not sent'}
        names = dict(COUNTERS)
        for key, value in self.counters:
            values[f'board {names[key]}'] = value
        return values

    def named(self) -> list:
        """Return the health as 'name: value' lines (skin_info's board_faults)."""
        return [f'{name[len("board "):]}: {value}' for name, value in self.values().items()]

    def problems(self, before: BoardHealth | None) -> list:
        """
        Return what a person should look at, each as a sentence.

        An alarming reset or a fault before it, a board running from its internal oscillator,
        and each counter that grew since ``before``.
        """
        problems = []
        if self.fault:
            problems.append(f'the board restarted after {FAULTS.get(self.fault, self.fault)}')
        elif self.reset in _ALARMING_RESETS:
            problems.append(f'the board was reset by its {RESET_CAUSES[self.reset]}')
        if self.clock == 'hsi':
            problems.append(f'the board runs from its {CLOCKS["hsi"]}')
        for key, name in COUNTERS:
            now = self.count(key)
            was = before.count(key) if before is not None else None
            # A board that restarted counts from 0 again: all of its count is new.
            grown = now if was is None or now is not None and now < was else (
                now - was if now is not None else 0)
            if grown:
                problems.append(f'{grown} {name}')
        return problems
