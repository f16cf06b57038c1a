/*
 * mearm_sim: run the mearm_servo firmware on a simulated ATmega328P (simavr) and talk to
 * it through stdin/stdout, as if through the Uno's USB serial port.
 *
 *   mearm_sim [-x SPEED] [-t] build/mearm_servo.elf
 *
 * stdin bytes go to UART0's receiver (with the UART's own flow control), UART0's
 * transmitter goes to stdout. Every servo pulse is reported on stderr as
 * "pulse <channel> <width in 0.1 us> <simulated ms>", measured in CPU cycles between the
 * pin's rising and falling edge. Simulated time is kept in step with the
 * wall clock (never ahead; when it falls behind, the time lost is dropped, never run
 * fast to catch up), so the firmware's timeouts mean what they say.
 *
 *   -x SPEED  simulated seconds per wall-clock second (default 1: real time; 0: as fast
 *             as the computer runs it). The firmware's timeouts are simulated time.
 *   -t        timing events for a host that keeps simulated time (mearm.sim.virtual_uno):
 *             each pulse line gets a fifth field, its rising edge [simulated us]; each
 *             newline the UART transmits is reported as "line <simulated us>"; and
 *             "time <simulated us>" every 5 ms of simulated time.
 *
 * stdin's bytes wait until the firmware has enabled UART0's receiver (Serial.begin): a
 * real chip loses what arrives before, and a pipe cannot wait for the banner. When stdin
 * closes, the firmware runs on until it has been quiet for 100 ms of simulated time (no
 * byte received or sent), so it answers what it was given: printf '0 V*F970\n' | mearm_sim
 * prints the banner and the reply. simavr's own messages go to stderr.
 * Build: make -C tools/arduino sim (needs libsimavr-dev, libelf-dev).
 */
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_irq.h>

#define F_CPU 16000000UL
#define SERVO_COUNT 5
/* ATmega328P's UCSR0B (data-space address) and its receiver-enable bit RXEN0. */
#define UCSR0B_ADDR 0xC1
#define RXEN0_BIT 4
/* After stdin closes: exit once nothing has crossed the UART for this long. */
#define QUIET_CYCLES (F_CPU / 10)
/* Simulated time may fall this far behind the wall clock [s] before the rest is dropped. */
#define MAX_LAG_S 0.02

/* Uno pins D3, D5, D6, D9, D10 = PD3, PD5, PD6, PB1, PB2 (mearm_servo.ino SERVO_PINS). */
static const char SERVO_PORT[SERVO_COUNT] = {'D', 'D', 'D', 'B', 'B'};
static const int SERVO_BIT[SERVO_COUNT] = {3, 5, 6, 1, 2};

static avr_t *avr;
static avr_cycle_count_t rise[SERVO_COUNT];
static int xoff = 0;
static int timing = 0; /* -t */
static avr_cycle_count_t last_io = 0; /* the cycle of the last byte in or out */

static unsigned long long sim_us(avr_cycle_count_t cycle) {
  return (unsigned long long)(cycle / (F_CPU / 1000000UL));
}

static void on_uart_out(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  (void)param;
  uint8_t byte = (uint8_t)value;
  last_io = avr->cycle;
  if (write(STDOUT_FILENO, &byte, 1) < 0) exit(0);
  if (timing && byte == '\n') {
    fprintf(stderr, "line %llu\n", sim_us(avr->cycle));
    fflush(stderr);
  }
}

static void on_xon(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq; (void)value; (void)param;
  xoff = 0;
}

static void on_xoff(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq; (void)value; (void)param;
  xoff = 1;
}

static void on_pin(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  int ch = (int)(intptr_t)param;
  if (value) {
    rise[ch] = avr->cycle;
    return;
  }
  if (!rise[ch]) return;
  /* width in 0.1 us: cycles * 10 / 16 */
  long width = (long)((avr->cycle - rise[ch]) * 10 / (F_CPU / 1000000UL));
  if (timing) {
    fprintf(stderr, "pulse %d %ld %lu %llu\n", ch, width,
            (unsigned long)(avr->cycle / (F_CPU / 1000UL)), sim_us(rise[ch]));
  } else {
    fprintf(stderr, "pulse %d %ld %lu\n", ch, width,
            (unsigned long)(avr->cycle / (F_CPU / 1000UL)));
  }
  rise[ch] = 0;
  fflush(stderr);
}

/* simavr's messages ("Loaded 4246 .text ...") on stderr: stdout is the UART's alone. */
static void log_to_stderr(avr_t *a, const int level, const char *format, va_list ap) {
  if (!a || a->log >= level) vfprintf(stderr, format, ap);
}

static double wall_s(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static int usage(FILE *to, const char *prog) {
  fprintf(to, "usage: %s [-x SPEED] [-t] FIRMWARE.elf\n", prog);
  return to == stdout ? 0 : 2;
}

/* One line and exit 2 for a file that is not an ELF (the .hex beside it, a folder, a
 * missing file): simavr would print lines of its own, or load the bytes and run garbage. */
static int check_elf(const char *prog, const char *path) {
  FILE *f = fopen(path, "rb");
  unsigned char magic[4] = {0};
  size_t n = f ? fread(magic, 1, sizeof(magic), f) : 0;
  int err = f ? (ferror(f) ? errno : 0) : errno;
  if (f) fclose(f);
  if (err) {
    fprintf(stderr, "%s: cannot read %s: %s\n", prog, path, strerror(err));
    return 2;
  }
  if (n < sizeof(magic) || memcmp(magic, "\x7f" "ELF", 4) != 0) {
    fprintf(stderr, "%s: cannot read %s: not an ELF file (give the firmware's .elf, "
            "build/mearm_servo.elf, not its .hex)\n", prog, path);
    return 2;
  }
  return 0;
}

int main(int argc, char **argv) {
  double speed = 1.0;
  int opt;
  if (argc == 2 && strcmp(argv[1], "--help") == 0) return usage(stdout, argv[0]);
  opterr = 0;
  while ((opt = getopt(argc, argv, "hx:t")) != -1) {
    if (opt == 'h') {
      return usage(stdout, argv[0]);
    } else if (opt == 't') {
      timing = 1;
    } else if (opt == 'x') {
      char *end;
      speed = strtod(optarg, &end);
      if (*end != '\0' || !(speed >= 0.0 && speed <= 1000.0)) {
        fprintf(stderr, "%s: -x takes a speed from 0 to 1000, got %s\n", argv[0], optarg);
        return 2;
      }
    } else {  /* one line, not getopt's own and the usage after it */
      fprintf(stderr, "%s: unknown option or missing value: -%c; usage: %s [-x SPEED] [-t] "
              "FIRMWARE.elf\n", argv[0], optopt, argv[0]);
      return 2;
    }
  }
  if (optind != argc - 1) return usage(stderr, argv[0]);
  avr_global_logger_set(log_to_stderr);
  const char *elf = argv[optind];
  if (check_elf(argv[0], elf) != 0) return 2;
  elf_firmware_t fw;
  memset(&fw, 0, sizeof(fw));
  if (elf_read_firmware(elf, &fw) != 0) {
    fprintf(stderr, "%s: cannot read %s\n", argv[0], elf);
    return 2;
  }
  avr = avr_make_mcu_by_name("atmega328p");
  if (!avr) return 2;
  avr_init(avr);
  avr->frequency = F_CPU;
  avr_load_firmware(avr, &fw);

  uint32_t flags = 0;
  avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~AVR_UART_FLAG_STDIO;
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                          on_uart_out, NULL);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                          on_xon, NULL);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                          on_xoff, NULL);
  avr_irq_t *uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
  for (int ch = 0; ch < SERVO_COUNT; ch++) {
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(SERVO_PORT[ch]),
                                          SERVO_BIT[ch]),
                            on_pin, (void *)(intptr_t)ch);
  }

  fcntl(STDIN_FILENO, F_SETFL, fcntl(STDIN_FILENO, F_GETFL) | O_NONBLOCK);
  uint8_t queue[4096];
  size_t head = 0, tail = 0;
  int stdin_open = 1;
  double start = wall_s();
  avr_cycle_count_t next_tick = 0;
  for (;;) {
    for (int i = 0; i < 2000; i++) {
      int state = avr_run(avr);
      if (state == cpu_Done || state == cpu_Crashed) {
        fprintf(stderr, "mearm_sim: the AVR stopped (state %d)\n", state);
        return 1;
      }
    }
    if (stdin_open && tail < sizeof(queue)) {
      ssize_t n = read(STDIN_FILENO, queue + tail, sizeof(queue) - tail);
      if (n > 0) tail += (size_t)n;
      else if (n == 0) stdin_open = 0;
      else if (errno != EAGAIN && errno != EWOULDBLOCK) stdin_open = 0;
    }
    if (!stdin_open && head == tail && avr->cycle - last_io > QUIET_CYCLES) return 0;
    if (head < tail && !xoff && (avr->data[UCSR0B_ADDR] & (1 << RXEN0_BIT))) {
      avr_raise_irq(uart_in, queue[head++]);
      last_io = avr->cycle;
    }
    if (head == tail) head = tail = 0;
    if (timing && avr->cycle >= next_tick) {
      fprintf(stderr, "time %llu\n", sim_us(avr->cycle));
      fflush(stderr);
      next_tick = avr->cycle + 5 * (F_CPU / 1000UL);
    }
    if (speed > 0.0) {
      double ahead = (double)avr->cycle / F_CPU / speed - (wall_s() - start);
      if (ahead > 0.002) usleep((useconds_t)(ahead * 1e6));
      /* Behind (the process was paused or starved on a loaded machine): the lost time is
       * dropped, not run flat out to catch up. A real chip's time does not jump, and a
       * burst would fire the firmware's 1 s watchdog between two of the host's lines. */
      else if (ahead < -MAX_LAG_S) start += -ahead - MAX_LAG_S;
    }
  }
}
