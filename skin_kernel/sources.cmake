# The kernel's sources, one file per stage of the scan (kernel.c runs them in order): the library
# (CMakeLists.txt) and its C tests (test/CMakeLists.txt) build the same list.
set(SKIN_KERNEL_SOURCES)
foreach(stage kernel condition crosstalk contacts mixture gaussian_cells solve centroid taxel_fit
              censored_fit phase_correlation model_fit uncertainty saturated_force direction drift)
  list(APPEND SKIN_KERNEL_SOURCES "${CMAKE_CURRENT_LIST_DIR}/src/${stage}.c")
endforeach()
