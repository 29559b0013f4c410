#!/usr/bin/env bash
# Cargo runner for thumbv7em-none-eabihf: boots ELF in QEMU's netduinoplus2 (an STM32F405) with
# exact instruction counting and decodes the defmt log. Usage: qemu-run.sh ELF [ARG...]; the ARGs
# become the firmware's semihosting command line ([OPTIONS] IMU_FILE OUT_FILE LAT LON H ALIGN_S [LOG_EVERY [CAL_FILE]]),
# paths relative to the current directory. Exits with the firmware's exit code.
# QEMU_ICOUNT_SHIFT=N (default 0) makes each guest instruction 2^N ns of virtual time: 0 is a
# 1000 MIPS core, 3 a 125 MIPS one (below a 168 MHz Cortex-M4 with flash wait states), so a run
# at 3 shows whether the firmware keeps up on the real part (timers keep virtual time).
set -uo pipefail
elf=$1
shift
for tool in qemu-system-arm defmt-print; do
  command -v "$tool" >/dev/null || { echo "qemu-run.sh: $tool not found (cargo xtask setup installs it)" >&2; exit 127; }
done
semi="enable=on,target=native,arg=firmware"
for a in "$@"; do
  # The firmware reads its arguments as one semihosting command line split at white space: a
  # path with a space in it would become two arguments and shift every one after it.
  if [[ "$a" =~ [[:space:]] ]]; then
    echo "qemu-run.sh: argument '$a' holds white space, which the firmware's semihosting command line cannot carry (rename the file or use a path without spaces)" >&2
    exit 3
  fi
  # QEMU's option syntax writes a comma inside a value as two (e.g. --lever-arm X,Y,Z).
  semi+=",arg=${a//,/,,}"
done
qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 -nographic -monitor none -serial null \
  -semihosting-config "$semi" -icount shift="${QEMU_ICOUNT_SHIFT:-0}",align=off,sleep=off -kernel "$elf" \
  | defmt-print -e "$elf" --show-skipped-frames
exit "${PIPESTATUS[0]}"
