"""
The rehosted Nucleo board: the unmodified Nucleo-F446RE image in an instruction-set emulator.

The ELF's loadable segments (what ``make flash`` writes) run on unicorn's Cortex-M4 with a model
of every STM32F446 peripheral the firmware touches, each written from the reference manual
RM0390 (Rev 4; sections cited where each model is). The ADCs sample a simulator scene through
the wiring table (skin_board_pins.h); the USART's bytes go to a pty the driver reads.

- elf: the image's segments and symbols;
- wiring: the expander's wiring as skin_board_pins.h gives it;
- clock: RCC, PWR and FLASH, and the clock tree computed from the firmware's writes;
- devices: GPIO, timers, ADCs, DMA, USART, CRC, IWDG, the system control space;
- otg: the OTG FS core in device mode (the USB image's link);
- usb_host: a scripted USB host on the OTG core's cable (enumeration, control, bulk IN);
- chip: the CPU, the bus, device time, the OTG interrupt's delivery and the fault switches;
- board: the chip on a pty, and the command line (``python -m skin_driver.tools.rehost``).
- cost: the instructions the image runs per scan, by part (``python -m ...rehost.cost --usb``).

docs/firmware.md, "The rehosted board", says what is modelled, what is not and how it is fast.
"""
