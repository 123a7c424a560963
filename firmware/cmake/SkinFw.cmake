# Helpers shared by the host build and the boards.
#
# skin_fw_add_firmware(<target>
#     CONFIG_DIR <dir with skin_fw_config.h>  LINKER_SCRIPT <file.ld>  SOURCES <board sources...>
#     [CRC32_HW] [FLASH_LIMIT <bytes>] [RAM_LIMIT <bytes>])
# builds <target>.elf from the board's sources and the core (compiled with the board's config,
# and with SKIN_FW_CRC32_HW when CRC32_HW is given), writes <target>.bin and <target>.map, and
# fails the build when text+data exceeds FLASH_LIMIT or data+bss (the stack included, if the
# linker script reserves it as a section) exceeds RAM_LIMIT.
# -DSKIN_FW_PROTOCOL=1 builds every board to send protocol version 1 instead of 2.

set(SKIN_FW_DIR "${CMAKE_CURRENT_LIST_DIR}/..")
# The wire protocol version every board image sends (docs/protocol.md): 2, or 1 on request.
set(SKIN_FW_PROTOCOL 2 CACHE STRING "wire protocol version of the boards' frames (1 or 2)")
set_property(CACHE SKIN_FW_PROTOCOL PROPERTY STRINGS 1 2)
set(SKIN_FW_WARNINGS -Wall -Wextra -Werror -Wpedantic)
set(SKIN_FW_CORE_SOURCES
    "${SKIN_FW_DIR}/core/src/crc.c"
    "${SKIN_FW_DIR}/core/src/fault.c"
    "${SKIN_FW_DIR}/core/src/frame.c"
    "${SKIN_FW_DIR}/core/src/clock.c"
    "${SKIN_FW_DIR}/core/src/info.c"
    "${SKIN_FW_DIR}/core/src/mux_check.c"
    "${SKIN_FW_DIR}/core/src/scan.c"
    "${SKIN_FW_DIR}/core/src/wait.c")
set(SKIN_FW_RUN_SOURCE "${SKIN_FW_DIR}/core/src/run.c")
set(SKIN_FW_VENDOR_INCLUDES
    "${SKIN_FW_DIR}/vendor/cmsis_core/Include"
    "${SKIN_FW_DIR}/vendor/cmsis_device_f4/Include")

function(skin_fw_add_firmware target)
  cmake_parse_arguments(ARG "CRC32_HW" "CONFIG_DIR;LINKER_SCRIPT;FLASH_LIMIT;RAM_LIMIT" "SOURCES"
                        ${ARGN})
  add_executable(${target} ${ARG_SOURCES} ${SKIN_FW_CORE_SOURCES} ${SKIN_FW_RUN_SOURCE})
  set_target_properties(${target} PROPERTIES SUFFIX ".elf" LINK_DEPENDS "${ARG_LINKER_SCRIPT}")
  target_include_directories(${target} PRIVATE "${ARG_CONFIG_DIR}" "${SKIN_FW_DIR}/core/include")
  # Vendor headers are not ours to keep warning-free.
  target_include_directories(${target} SYSTEM PRIVATE ${SKIN_FW_VENDOR_INCLUDES})
  target_compile_options(${target} PRIVATE ${SKIN_FW_WARNINGS} -Os -g)
  target_compile_definitions(${target} PRIVATE SKIN_FW_PROTOCOL=${SKIN_FW_PROTOCOL})
  if(ARG_CRC32_HW)
    target_compile_definitions(${target} PRIVATE SKIN_FW_CRC32_HW)
  endif()
  set(out "$<TARGET_FILE_DIR:${target}>/${target}")
  target_link_options(${target} PRIVATE "-T${ARG_LINKER_SCRIPT}" "-Wl,-Map=${out}.map")
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND "${CMAKE_OBJCOPY}" -O binary "$<TARGET_FILE:${target}>" "${out}.bin"
    COMMAND "${CMAKE_COMMAND}" -DSIZE_TOOL=${CMAKE_SIZE} "-DELF=$<TARGET_FILE:${target}>"
            -DFLASH_LIMIT=${ARG_FLASH_LIMIT} -DRAM_LIMIT=${ARG_RAM_LIMIT}
            -P "${SKIN_FW_DIR}/cmake/check_size.cmake"
    VERBATIM)
endfunction()
