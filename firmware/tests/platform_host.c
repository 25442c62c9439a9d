/* The core's tests on the development machine: libsodium's keyed BLAKE2b (the MAC the emulator
 * uses), CLOCK_MONOTONIC in ns. */
#define _POSIX_C_SOURCE 199309L
#include "test_platform.h"

#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

void test_platform_init(void) {
  if (sodium_init() < 0) {
    printf("libsodium failed to initialise\n");
    exit(2);
  }
}

void test_mac(void* ctx, const uint8_t key[MFB_KEY_SIZE], const uint8_t* data, size_t size, uint8_t out[MFB_MAC_SIZE]) {
  (void)ctx;
  crypto_generichash(out, MFB_MAC_SIZE, data, size, key, MFB_KEY_SIZE);
}

uint64_t test_ticks(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (uint64_t)t.tv_sec * 1000000000u + (uint64_t)t.tv_nsec;
}

void test_report_cost(const char* what, uint64_t ticks) { printf("  cost: %s: %llu ns\n", what, (unsigned long long)ticks); }

int test_platform_exit(int failed) { return failed; }
