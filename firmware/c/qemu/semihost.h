/* ARM semihosting (BKPT 0xAB on ARMv6-M): host files, as QEMU's
 * -semihosting-config enable=on,target=native serves them. */
#ifndef TC_SEMIHOST_H
#define TC_SEMIHOST_H

#include <stddef.h>
#include <stdint.h>

enum { SH_OPEN = 0x01, SH_WRITE = 0x05, SH_READ = 0x06, SH_EXIT_EXTENDED = 0x20 };
enum { SH_MODE_RB = 1, SH_MODE_WB = 5 };

static inline int sh_call(int op, const void *arg)
{
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

/* A host file (a FIFO here); its handle, or -1. */
static inline int sh_open(const char *name, size_t len, int mode)
{
    uint32_t a[3];
    a[0] = (uint32_t)(uintptr_t)name;
    a[1] = (uint32_t)mode;
    a[2] = (uint32_t)len;
    return sh_call(SH_OPEN, a);
}

/* Write all of data; 0, or the bytes not written. */
static inline int sh_write(int fd, const void *data, size_t n)
{
    uint32_t a[3];
    a[0] = (uint32_t)fd;
    a[1] = (uint32_t)(uintptr_t)data;
    a[2] = (uint32_t)n;
    return sh_call(SH_WRITE, a);
}

/* Read up to n bytes (a pipe gives what it has): the bytes NOT read (n at end of file). */
static inline int sh_read(int fd, void *buf, size_t n)
{
    uint32_t a[3];
    a[0] = (uint32_t)fd;
    a[1] = (uint32_t)(uintptr_t)buf;
    a[2] = (uint32_t)n;
    return sh_call(SH_READ, a);
}

/* QEMU exits with status `code`. */
static inline void sh_exit(uint32_t code)
{
    uint32_t a[2];
    a[0] = 0x20026u; /* ADP_Stopped_ApplicationExit */
    a[1] = code;
    sh_call(SH_EXIT_EXTENDED, a);
    for (;;) {
    }
}

#endif
