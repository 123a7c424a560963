#include "skin_fw/fw.h"

int main(void) { skin_fw_run(); }
