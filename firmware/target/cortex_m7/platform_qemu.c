/* The core's tests on an emulated Cortex-M7 (QEMU mps2-an500, semihosting): the MAC from the BLAKE2
 * reference code (Debian's libb2 source, blake2b-ref.c, built for the target), instruction counts
 * from SysTick under `-icount shift=0` (one instruction = 1 ns of virtual time), the end through
 * the semihosting exit call (picolibc's exit). */
#include "test_platform.h"

/* libb2's blake2b-ref.c, built with -DSUFFIX=_ref: BLAKE2b with a key (RFC 7693). */
int blake2b_ref(uint8_t* out, const void* in, const void* key, size_t outlen, size_t inlen, size_t keylen);

#include <stdio.h>
#include <stdlib.h>

#define SYST_CSR (*(volatile uint32_t*)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t*)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t*)0xE000E018u)

static uint32_t g_last;
static uint64_t g_ticks;
/* Instructions per SysTick tick, measured at start-up on a loop of known length (x1000). */
static uint64_t g_milli_instructions_per_tick;

uint64_t test_ticks(void) {
  /* A 24-bit down-counter; read often enough (< 2^24 ticks apart) it extends to 64 bits. */
  const uint32_t now = SYST_CVR & 0xFFFFFFu;
  g_ticks += (g_last - now) & 0xFFFFFFu;
  g_last = now;
  return g_ticks;
}

static void spin(uint32_t n) { __asm volatile("1: subs %0, %0, #1\n bne 1b" : "+r"(n)); }

void test_platform_init(void) {
  SYST_RVR = 0xFFFFFFu;
  SYST_CVR = 0;
  SYST_CSR = 0x5u; /* processor clock, enabled, no interrupt */
  g_last = SYST_CVR & 0xFFFFFFu;
  enum { kLoops = 1000000 };
  const uint64_t t0 = test_ticks();
  spin(kLoops);
  const uint64_t t1 = test_ticks();
  g_milli_instructions_per_tick = t1 > t0 ? (uint64_t)2 * kLoops * 1000u / (t1 - t0) : 0;
  printf("platform: Cortex-M7 on QEMU; SysTick: %llu.%03llu instructions per tick\n",
         (unsigned long long)(g_milli_instructions_per_tick / 1000), (unsigned long long)(g_milli_instructions_per_tick % 1000));
}

void test_mac(void* ctx, const uint8_t key[MFB_KEY_SIZE], const uint8_t* data, size_t size, uint8_t out[MFB_MAC_SIZE]) {
  (void)ctx;
  blake2b_ref(out, data, key, MFB_MAC_SIZE, size, MFB_KEY_SIZE);
}

void test_report_cost(const char* what, uint64_t ticks) {
  printf("  cost: %s: %llu instructions\n", what, (unsigned long long)(ticks * g_milli_instructions_per_tick / 1000u));
}

int test_platform_exit(int failed) {
  fflush(stdout);
  exit(failed);
}
