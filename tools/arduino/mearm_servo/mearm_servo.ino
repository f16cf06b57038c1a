// mearm_servo: servo pulses for the MeArm colour sorter on an Arduino Uno, commanded over
// USB serial with the line protocol of ../PROTOCOL.md (keep the two in step, and the
// Python side in mearm/hardware/mearm_protocol.py and tests/fakeboard.py).
//
// The pulses come from Timer1 (prescaler 8: 0.5 us per tick at 16 MHz), one servo after
// the other in a 20 ms frame, as the Arduino Servo library does -- but without it: Debian
// does not package that library. A move updates all channels at once, at the start of a
// frame, so no frame ever mixes two commands.
//
// Opens as is in the Arduino IDE; `make -C tools/arduino` builds it with Debian's avr-gcc.

#include <Arduino.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <stdlib.h>
#include <string.h>
#include <util/crc16.h>

// ---------------------------------------------------------------- configuration

#define FIRMWARE_NAME "mearm_servo"
// major.minor; the host refuses another major version. 2: lines end in a CRC-16 (1: an XOR).
#define FIRMWARE_VERSION "2.0"
#define BAUD 115200UL
#define SERVO_COUNT 5
// Channel i drives pin SERVO_PINS[i]: 0 theta1, 1 theta2, 2 theta3, 3 theta5, 4 gripper
// with the default config (servo.joints / servo.gripper choose the channels).
// SERVO_PIN_<i> rewires channel i for a test build, e.g. two channels swapped:
// make -C tools/arduino BUILD_DIR=/tmp/swapped EXTRA_DEFS="-DSERVO_PIN_1=6 -DSERVO_PIN_2=5"
#ifndef SERVO_PIN_0
#define SERVO_PIN_0 3
#endif
#ifndef SERVO_PIN_1
#define SERVO_PIN_1 5
#endif
#ifndef SERVO_PIN_2
#define SERVO_PIN_2 6
#endif
#ifndef SERVO_PIN_3
#define SERVO_PIN_3 9
#endif
#ifndef SERVO_PIN_4
#define SERVO_PIN_4 10
#endif
static const uint8_t SERVO_PINS[SERVO_COUNT] = {SERVO_PIN_0, SERVO_PIN_1, SERVO_PIN_2,
                                                SERVO_PIN_3, SERVO_PIN_4};
#define MIN_PULSE_US 500
#define MAX_PULSE_US 2500
#define FRAME_US 20000UL        // 50 Hz servo frame
#define HOLD_TIMEOUT_MS 1000UL  // no valid command for this long: HOLD
#define MAX_LINE 80             // longest line, without the newline
#define MAX_ARGS 8

// Error numbers (PROTOCOL.md).
#define E_CHECKSUM 1
#define E_MALFORMED 2
#define E_UNKNOWN_COMMAND 3
#define E_ARGUMENT_COUNT 4
#define E_PULSE_RANGE 5
#define E_LINE_TOO_LONG 6

#define TICKS_PER_US (F_CPU / 8000000UL)
#define FRAME_TICKS ((uint16_t)(FRAME_US * TICKS_PER_US))
#define EMPTY_SLOT_TICKS ((uint16_t)(50 * TICKS_PER_US))
// From the compare match to the pin going low the ISR takes ~4.5 us (entry + prologue),
// so each pulse is timed that much short. Measured on the simulated ATmega328P by
// tests/test_firmware.py, which checks every channel's width to within 1 us.
#define PULSE_TRIM_TICKS 9

// ---------------------------------------------------------------- pulse generation

static volatile uint16_t pending_ticks[SERVO_COUNT];  // written by loop()
static volatile uint8_t pending_ready = 0;
static uint16_t active_ticks[SERVO_COUNT];  // read by the ISR only; 0 = no pulse
static volatile uint8_t *pin_port[SERVO_COUNT];
static uint8_t pin_mask[SERVO_COUNT];
static volatile int8_t slot = -1;  // channel whose pulse is running; -1 = frame tail

ISR(TIMER1_COMPA_vect) {
  if (slot < 0) {
    TCNT1 = 0;  // a new frame
    if (pending_ready) {
      for (uint8_t i = 0; i < SERVO_COUNT; i++) active_ticks[i] = pending_ticks[i];
      pending_ready = 0;
    }
  } else if (active_ticks[slot]) {
    *pin_port[slot] &= ~pin_mask[slot];  // end of this channel's pulse
  }
  slot++;
  if (slot < SERVO_COUNT) {
    uint16_t ticks = active_ticks[slot];
    if (ticks) {
      *pin_port[slot] |= pin_mask[slot];
      OCR1A = TCNT1 + ticks - PULSE_TRIM_TICKS;
    } else {
      OCR1A = TCNT1 + EMPTY_SLOT_TICKS;
    }
  } else {
    uint16_t now = TCNT1 + 8;
    OCR1A = now < FRAME_TICKS ? FRAME_TICKS : now;
    slot = -1;
  }
}

static void start_pulses(void) {
  for (uint8_t i = 0; i < SERVO_COUNT; i++) {
    pinMode(SERVO_PINS[i], OUTPUT);
    digitalWrite(SERVO_PINS[i], LOW);
    pin_port[i] = portOutputRegister(digitalPinToPort(SERVO_PINS[i]));
    pin_mask[i] = digitalPinToBitMask(SERVO_PINS[i]);
    active_ticks[i] = 0;
  }
  cli();
  TCCR1A = 0;            // normal mode (the core set it up for PWM)
  TCCR1B = _BV(CS11);    // prescaler 8
  TCNT1 = 0;
  OCR1A = FRAME_TICKS;
  TIFR1 = _BV(OCF1A);
  TIMSK1 |= _BV(OCIE1A);
  sei();
}

// Takes effect at the start of the next frame, all channels together.
static void set_pulses(const uint16_t *us) {
  uint8_t sreg = SREG;
  cli();
  for (uint8_t i = 0; i < SERVO_COUNT; i++) pending_ticks[i] = us[i] * TICKS_PER_US;
  pending_ready = 1;
  SREG = sreg;
}

// ---------------------------------------------------------------- replies

static char out[72];
static uint8_t out_len = 0;
static char last_reply[72];
static uint8_t last_reply_len = 0;
static const char HEX_DIGITS[] = "0123456789ABCDEF";

static void out_begin(void) { out_len = 0; }

// Room kept at the end of out[] for "*HHHH\n".
#define CHECK_TAIL 6

static void out_str(const char *s) {
  while (*s && out_len < sizeof(out) - CHECK_TAIL) out[out_len++] = *s++;
}

static void out_uint(unsigned int v) {
  char buf[8];
  utoa(v, buf, 10);
  out_str(" ");
  out_str(buf);
}

// CRC-16/XMODEM (polynomial 0x1021, initial value 0) of n bytes: avr-libc's, as the
// host's binascii.crc_hqx(data, 0).
static uint16_t crc16(const char *data, uint8_t n) {
  uint16_t crc = 0;
  for (uint8_t i = 0; i < n; i++) crc = _crc_xmodem_update(crc, (uint8_t)data[i]);
  return crc;
}

// Appends *HHHH and the newline, sends, and keeps it for a duplicate frame if asked.
static void out_send(bool remember) {
  uint16_t crc = crc16(out, out_len);
  out[out_len++] = '*';
  for (int8_t shift = 12; shift >= 0; shift -= 4) {
    out[out_len++] = HEX_DIGITS[(crc >> shift) & 0x0F];
  }
  out[out_len++] = '\n';
  Serial.write((const uint8_t *)out, out_len);
  if (remember) {
    memcpy(last_reply, out, out_len);
    last_reply_len = out_len;
  }
}

// ERR <seq|-> <code> <word>; seq < 0 prints '-'.
static void reply_error(int seq, uint8_t code, const char *word) {
  out_begin();
  out_str("ERR");
  if (seq < 0) {
    out_str(" -");
  } else {
    out_uint((unsigned int)seq);
  }
  out_uint(code);
  out_str(" ");
  out_str(word);
  out_send(seq >= 0);
}

// ---------------------------------------------------------------- state

enum Mode { MODE_IDLE, MODE_RUN, MODE_HOLD };
static Mode mode = MODE_IDLE;
static uint16_t current_us[SERVO_COUNT];  // 0 = no pulse
static unsigned long last_valid_ms = 0;
static bool have_last = false;
static uint8_t last_seq = 0;
static uint16_t last_crc = 0;

static const char *mode_name(void) {
  return mode == MODE_RUN ? "RUN" : (mode == MODE_HOLD ? "HOLD" : "IDLE");
}

// ---------------------------------------------------------------- parsing

static int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// A token of 1..max_digits decimal digits; returns -1 otherwise.
static long parse_uint(const char *s, uint8_t max_digits) {
  uint8_t n = 0;
  long v = 0;
  for (; *s; s++, n++) {
    if (*s < '0' || *s > '9' || n >= max_digits) return -1;
    v = v * 10 + (*s - '0');
  }
  return n ? v : -1;
}

// One complete line (no newline): check, then act. Same order as tests/fakeboard.py.
static void handle_line(char *line) {
  char *star = strrchr(line, '*');
  if (star == NULL || strlen(star) != 5) {
    reply_error(-1, E_MALFORMED, "syntax");
    return;
  }
  uint16_t sent_crc = 0;
  for (uint8_t i = 1; i <= 4; i++) {
    int digit = hex_value(star[i]);
    if (digit < 0) {
      reply_error(-1, E_MALFORMED, "syntax");
      return;
    }
    sent_crc = (uint16_t)(sent_crc << 4 | digit);
  }
  for (char *p = line; p < star; p++) {
    if (*p < 0x20 || *p > 0x7E) {
      reply_error(-1, E_MALFORMED, "syntax");
      return;
    }
  }
  uint16_t crc = crc16(line, (uint8_t)(star - line));
  if (crc != sent_crc) {
    reply_error(-1, E_CHECKSUM, "checksum");
    return;
  }
  *star = '\0';
  // One space between fields, none around them (PROTOCOL.md): strtok alone would take
  // "5  M" or "5 V " as well formed, where the fake board of the tests refuses them.
  if (line[0] == ' ') {
    reply_error(-1, E_MALFORMED, "syntax");
    return;
  }
  bool bad_arg = strstr(line, "  ") != NULL || (star > line && star[-1] == ' ');

  char *tokens[2] = {NULL, NULL};  // seq, command
  uint16_t args[MAX_ARGS];
  uint8_t ntok = 0;
  uint8_t nargs = 0;
  for (char *tok = strtok(line, " "); tok != NULL; tok = strtok(NULL, " ")) {
    if (ntok < 2) {
      tokens[ntok++] = tok;
      continue;
    }
    long v = parse_uint(tok, 5);
    if (v < 0) bad_arg = true;
    if (nargs < MAX_ARGS) args[nargs] = (uint16_t)(v > 65535L ? 65535L : (v < 0 ? 0 : v));
    if (nargs < 255) nargs++;
  }
  long seq = ntok ? parse_uint(tokens[0], 3) : -1;
  if (seq < 0 || seq > 255) {
    reply_error(-1, E_MALFORMED, "syntax");
    return;
  }
  if (have_last && (uint8_t)seq == last_seq && crc == last_crc) {
    Serial.write((const uint8_t *)last_reply, last_reply_len);  // a resend: do not act twice
    return;
  }
  have_last = true;
  last_seq = (uint8_t)seq;
  last_crc = crc;
  last_valid_ms = millis();

  if (ntok < 2 || strlen(tokens[1]) != 1 || bad_arg) {
    reply_error(seq, E_MALFORMED, "syntax");
    return;
  }
  char command = tokens[1][0];
  uint8_t expected;
  switch (command) {
    case 'V': case 'S': case 'Q': expected = 0; break;
    case 'M': expected = SERVO_COUNT; break;
    default:
      reply_error(seq, E_UNKNOWN_COMMAND, "command");
      return;
  }
  if (nargs != expected) {
    reply_error(seq, E_ARGUMENT_COUNT, "args");
    return;
  }

  out_begin();
  out_str("OK");
  out_uint((unsigned int)seq);
  if (command == 'V') {
    out_str(" " FIRMWARE_NAME " " FIRMWARE_VERSION);
    out_uint(SERVO_COUNT);
    out_uint(MIN_PULSE_US);
    out_uint(MAX_PULSE_US);
  } else if (command == 'M') {
    for (uint8_t i = 0; i < SERVO_COUNT; i++) {
      if (args[i] != 0 && (args[i] < MIN_PULSE_US || args[i] > MAX_PULSE_US)) {
        char word[6] = "ch";
        utoa(i, word + 2, 10);
        reply_error(seq, E_PULSE_RANGE, word);
        return;
      }
    }
    for (uint8_t i = 0; i < SERVO_COUNT; i++) current_us[i] = args[i];
    set_pulses(current_us);
    mode = MODE_RUN;
  } else if (command == 'S') {
    if (mode == MODE_RUN) mode = MODE_HOLD;
  } else {  // 'Q'
    out_str(" ");
    out_str(mode_name());
    for (uint8_t i = 0; i < SERVO_COUNT; i++) out_uint(current_us[i]);
  }
  out_send(true);
}

// ---------------------------------------------------------------- main

static char line[MAX_LINE + 1];
static uint8_t line_len = 0;
static bool overflow = false;
static unsigned long last_byte_ms = 0;

void setup() {
  Serial.begin(BAUD);
  start_pulses();  // no pulses until the first M: the arm's pose is unknown at boot
  out_begin();
  out_str("READY " FIRMWARE_NAME " " FIRMWARE_VERSION);
  out_uint(SERVO_COUNT);
  out_send(false);
}

void loop() {
  while (Serial.available() > 0) {
    char c = (char)Serial.read();
    last_byte_ms = millis();
    if (c == '\n' || c == '\r') {
      if (overflow) {
        reply_error(-1, E_LINE_TOO_LONG, "long");
      } else if (line_len > 0) {
        line[line_len] = '\0';
        handle_line(line);
      }
      line_len = 0;
      overflow = false;
    } else if (line_len < MAX_LINE) {
      line[line_len++] = c;
    } else {
      overflow = true;
    }
  }
  unsigned long now = millis();
  if (line_len > 0 && now - last_byte_ms > HOLD_TIMEOUT_MS) {
    line_len = 0;  // half a line from a host that went away
    overflow = false;
  }
  if (mode == MODE_RUN && now - last_valid_ms > HOLD_TIMEOUT_MS) {
    mode = MODE_HOLD;  // keep the last pulses: stiff where it is, never limp
    out_begin();
    out_str("! HOLD");
    out_send(false);
  }
}
