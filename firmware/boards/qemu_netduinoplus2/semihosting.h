/*
 * ARM semihosting (bkpt 0xAB): the emulated board's "ADC" reads pre-rendered scans from a host
 * file through QEMU (-semihosting-config enable=on,target=native).
 */
#ifndef SEMIHOSTING_H
#define SEMIHOSTING_H

#include <stdint.h>

/* Issue semihosting operation op with parameter block arg; return r0 (semihosting.S). */
int32_t semihost_call(uint32_t op, void *arg);

int32_t semihost_open(const char *path);                       /* handle, or -1 */
int32_t semihost_read(int32_t handle, void *buf, uint32_t len); /* bytes read, or -1 */
int32_t semihost_seek(int32_t handle, uint32_t pos);           /* 0 on success */
void semihost_write0(const char *text);
void semihost_exit(void) __attribute__((noreturn));

#endif
