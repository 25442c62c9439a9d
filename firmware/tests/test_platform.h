/* What the core's tests need from the machine they run on: the MAC (a vetted BLAKE2b), a tick
 * counter for the cost figures, and the way to end. One implementation per platform:
 * tests/platform_host.c (libsodium, the monotonic clock) and target/cortex_m7/platform_qemu.c
 * (the BLAKE2 reference code from Debian's libb2 source, SysTick, semihosting). */
#ifndef PEHA_FIRMWARE_TEST_PLATFORM_H
#define PEHA_FIRMWARE_TEST_PLATFORM_H

#include "mfb_wire.h"

void test_platform_init(void);
void test_mac(void* ctx, const uint8_t key[MFB_KEY_SIZE], const uint8_t* data, size_t size, uint8_t out[MFB_MAC_SIZE]);
uint64_t test_ticks(void);
/* Prints `what` costs `ticks` per call, in the platform's unit (ns on the host, instructions on QEMU). */
void test_report_cost(const char* what, uint64_t ticks);
/* Ends the program with `failed` as its status (never returns on the target). */
int test_platform_exit(int failed);

#endif
