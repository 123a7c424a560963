#include "semihosting.h"

#include <string.h>

#define SYS_OPEN 0x01u
#define SYS_WRITE0 0x04u
#define SYS_READ 0x06u
#define SYS_SEEK 0x0Au
#define SYS_EXIT 0x18u
#define MODE_READ_BINARY 1u
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u

int32_t semihost_open(const char *path) {
  uint32_t block[3] = {(uint32_t)(uintptr_t)path, MODE_READ_BINARY, (uint32_t)strlen(path)};
  return semihost_call(SYS_OPEN, block);
}

int32_t semihost_read(int32_t handle, void *buf, uint32_t len) {
  uint32_t block[3] = {(uint32_t)handle, (uint32_t)(uintptr_t)buf, len};
  const int32_t not_read = semihost_call(SYS_READ, block);
  return not_read < 0 ? -1 : (int32_t)len - not_read;
}

int32_t semihost_seek(int32_t handle, uint32_t pos) {
  uint32_t block[2] = {(uint32_t)handle, pos};
  return semihost_call(SYS_SEEK, block);
}

void semihost_write0(const char *text) { (void)semihost_call(SYS_WRITE0, (void *)text); }

void semihost_exit(void) {
  /* On 32-bit targets the reason itself is the parameter. */
  (void)semihost_call(SYS_EXIT, (void *)(uintptr_t)ADP_STOPPED_APPLICATION_EXIT);
  for (;;) {
  }
}
