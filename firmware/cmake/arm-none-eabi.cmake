# CMake toolchain file for the Cortex-M4F boards (STM32F4: Nucleo-F446RE, QEMU netduinoplus2).
# Use: cmake -S firmware -B build/fw-arm -DCMAKE_TOOLCHAIN_FILE=firmware/cmake/arm-none-eabi.cmake
# The top-level CMakeLists sees CMAKE_CROSSCOMPILING and builds the boards instead of the host tests.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

set(SKIN_FW_TRIPLE arm-none-eabi)
find_program(CMAKE_C_COMPILER ${SKIN_FW_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_ASM_COMPILER ${SKIN_FW_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_OBJCOPY ${SKIN_FW_TRIPLE}-objcopy REQUIRED)
find_program(CMAKE_SIZE ${SKIN_FW_TRIPLE}-size REQUIRED)

# try_compile cannot link a bare-metal program without a linker script: compile a library.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(SKIN_FW_CPU_FLAGS "-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16")
set(CMAKE_C_FLAGS_INIT "${SKIN_FW_CPU_FLAGS} -ffunction-sections -fdata-sections")
set(CMAKE_ASM_FLAGS_INIT "${SKIN_FW_CPU_FLAGS}")
# newlib-nano keeps printf/malloc small; nosys stubs the system calls the image never makes.
set(CMAKE_EXE_LINKER_FLAGS_INIT
    "${SKIN_FW_CPU_FLAGS} --specs=nano.specs --specs=nosys.specs -Wl,--gc-sections")

set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
