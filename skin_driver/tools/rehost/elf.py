"""The parts of an ELF32 (little-endian, ARM) image the rehost needs: segments and symbols."""

from __future__ import annotations

from dataclasses import dataclass
import struct

PT_LOAD = 1
SHT_SYMTAB = 2
STT_FUNC = 2


@dataclass(frozen=True)
class Segment:
    """A loadable segment: its file bytes land at its physical (load) address."""

    paddr: int
    vaddr: int
    data: bytes
    memsz: int


@dataclass(frozen=True, order=True)
class Function:
    """A function's code: [start, end) without the Thumb bit, and its name."""

    start: int
    end: int
    name: str


class ElfImage:
    """
    An ARM ELF executable: the bytes ``make flash`` writes, and its symbol table.

    ``symbols`` maps a name to (value, size); ``functions`` lists the functions of a size
    (Function, by address), for telling which one an address is in.
    """

    def __init__(self, data: bytes):
        """Parse data; raise ValueError when it is not a 32-bit little-endian ARM ELF."""
        if data[:4] != b'\x7fELF' or data[4] != 1 or data[5] != 1:
            raise ValueError('not a 32-bit little-endian ELF file')
        (_, machine, _, self.entry, phoff, shoff, _, _, phentsize, phnum, shentsize,
         shnum, _) = struct.unpack_from('<HHIIIIIHHHHHH', data, 16)
        if machine != 40:
            raise ValueError(f'not an ARM image (e_machine {machine})')
        self.data = bytes(data)
        self.segments = []
        for i in range(phnum):
            (ptype, offset, vaddr, paddr, filesz, memsz, _, _) = struct.unpack_from(
                '<IIIIIIII', data, phoff + i * phentsize)
            if ptype == PT_LOAD and filesz:
                self.segments.append(Segment(paddr, vaddr, bytes(data[offset:offset + filesz]),
                                             memsz))
        self.symbols, self.functions = self._symbols(data, shoff, shentsize, shnum)

    @classmethod
    def load(cls, path) -> ElfImage:
        """Read and parse the ELF file at path."""
        with open(path, 'rb') as f:
            return cls(f.read())

    @staticmethod
    def _symbols(data: bytes, shoff: int, shentsize: int, shnum: int) -> dict:
        sections = [struct.unpack_from('<IIIIIIIIII', data, shoff + i * shentsize)
                    for i in range(shnum)]
        symbols, functions = {}, []
        for _, stype, _, _, offset, size, link, _, _, entsize in sections:
            if stype != SHT_SYMTAB:
                continue
            strtab = sections[link]
            names = data[strtab[4]:strtab[4] + strtab[5]]
            for at in range(offset, offset + size, entsize):
                name, value, sym_size, info, _, _ = struct.unpack_from('<IIIBBH', data, at)
                text = names[name:names.index(b'\0', name)].decode('ascii', 'replace')
                if text:
                    symbols[text] = (value, sym_size)
                    if info & 0xF == STT_FUNC and sym_size:
                        start = value & ~1
                        functions.append(Function(start, start + sym_size, text))
        return symbols, sorted(functions)

    def address(self, name: str) -> int:
        """Return the address of the symbol name (KeyError names it when absent)."""
        if name not in self.symbols:
            raise KeyError(f'no symbol {name!r} in the image')
        return self.symbols[name][0]

    def file_offset(self, address: int) -> int:
        """Return where in the file the byte loaded at address lies (ValueError if nowhere)."""
        for i, seg in enumerate(self.segments):
            if seg.vaddr <= address < seg.vaddr + len(seg.data):
                # Locate the segment's bytes in the file by their program header.
                return self._segment_offset(i) + address - seg.vaddr
        raise ValueError(f'address {address:#x} is in no loaded segment')

    def _segment_offset(self, index: int) -> int:
        phoff, = struct.unpack_from('<I', self.data, 28)
        phentsize, phnum = struct.unpack_from('<HH', self.data, 42)
        loads = [i for i in range(phnum)
                 if struct.unpack_from('<II', self.data, phoff + i * phentsize)[0] == PT_LOAD
                 and struct.unpack_from('<I', self.data, phoff + i * phentsize + 16)[0]]
        return struct.unpack_from('<I', self.data, phoff + loads[index] * phentsize + 4)[0]

    def patched(self, symbol: str, offset: int, new: bytes) -> ElfImage:
        """Return a copy with the bytes of symbol from offset replaced by new (a variant image)."""
        at = self.file_offset(self.address(symbol) + offset)
        data = bytearray(self.data)
        data[at:at + len(new)] = new
        return ElfImage(bytes(data))
