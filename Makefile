# Two commands on a fresh machine: `make demo` and `make test`. Both set up what they need first.
SHELL := /bin/bash
RUN := tools/with-env.sh

.PHONY: setup test stress demo bench soak soak-rehost lint clean firmware flash

setup:
	@bash tools/setup.sh

test: setup
	@bash tools/run-tests.sh $(ARGS)

# The whole suite N times on a fresh clone, under a CPU load on every core (docs/reliability.md):
# ARGS="--runs 5 --load 60", or --no-load.
stress:
	@bash tools/stress.sh $(ARGS)

demo: setup
	@$(RUN) python -m skin_lab.demo $(ARGS)

# The board images (build/fw-arm/boards/*/*.elf, .bin); installs the toolchain as root.
firmware:
	@bash tools/setup-firmware.sh && bash tools/build-firmware.sh

# The Nucleo-F446RE image through its ST-LINK with st-flash (stlink-tools); OpenOCD instead:
# cmake --build build/fw-arm --target flash-openocd. LINK=usb writes the USB image (the link
# over the expander's USB connector) instead of the USART one. docs/firmware.md.
LINK ?= usart
flash: firmware
	@cmake -DSKIN_FW_LINK=$(LINK) build/fw-arm >/dev/null && cmake --build build/fw-arm --target flash

bench: setup
	@$(RUN) python -m skin_lab.bench.cli $(ARGS)

soak: setup
	@$(RUN) python -m skin_driver.tools.soak $(ARGS)

# The unmodified Nucleo image on the rehosted chip: 10 000 scans through the driver (docs/firmware.md).
soak-rehost: setup
	@SKIN_REHOST_SCANS=10000 $(RUN) python -m pytest -q -n 0 -s --timeout 1800 \
		test/firmware/test_rehost_board.py -k thousand

lint: setup
	@$(RUN) python -m pytest -q -m linter

clean:
	rm -rf build install log .venv .venv-setup.log build-colcon.log
