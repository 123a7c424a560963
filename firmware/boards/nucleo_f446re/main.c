/* The Nucleo-F446RE firmware: everything after reset is the core's loop. */
#include "skin_fw/fw.h"

int main(void) { skin_fw_run(); }
