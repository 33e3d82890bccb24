// An emulated Raspberry Pi Pico: the RP2040 of the npm package rp2040js, run by node for
// tactile_sim.emulator.pico_core, which owns everything outside the chip.
//
// Wiring only, no model: the boot ROM and the flash come from files; the chip's USB CDC and
// its two I2C controllers are bridged to the Python parent over three pipes:
//   fd 3 (to Python):   'U' USB bytes from the chip, 'A'/'W'/'R' I2C, 'T' time, 'X' reset,
//                        'C' USB configured, 'E' fatal, 'L' log line;
//   fd 4 (from Python): the answers to 'A' (status, then until when the address ACKs: 9
//                        bytes) and 'R' (the same, then READ_AHEAD bytes), read
//                        synchronously, so the chip stands still while Python answers;
//   fd 5 (from Python): 'H' bytes for the chip's USB OUT endpoint, 'P' hold/run, 'Q' quit.
// Each message: type (1 byte), payload length (u16 LE), payload.
//
// The ADS122C04s are Python's (the same models every core uses). A write's address phase is
// asked for ('A', at the chip's time) unless Python's last answer for that address said it
// ACKs until a later time (no fault due before); its bytes go at STOP ('W'). A read's address
// phase asks for the bytes the read returns, with the bytes written before the repeated
// start ('R'): a device cannot know how many bytes the controller will clock out, so they are
// asked for once and handed out as the controller reads them. Each bus event completes
// after its bit times at the controller's own SCL period (hcnt + lcnt system clocks), so
// the bus costs the chip what it costs on a board.
//
// Flash: rp2040js reads flash but does not program it. The boot ROM's flash_range_erase
// ('RE') and flash_range_program ('RP') entries are replaced by BKPT; the break handler
// applies the operation to the flash array and to the flash file at once, then returns to
// LR. A watchdog reset (machine.reset()) restarts the chip on the same flash. With
// cfg.flash_journal, each operation is also appended to that file as it is applied (u32 LE
// offset, u32 LE length, the bytes the range then holds), so a test can rebuild the flash
// as a power cut after any operation would have left it.
//
// The flash chip's unique id (machine.unique_id(), the board id in HELLO): rp2040js answers
// every read of the SSI's data register with 0, so every emulated Pico would read the id
// 0000000000000000. pico-sdk reads it at start-up with the flash command 0x4B (RUID): with
// chip select forced low (IO_QSPI SS_CTRL), the command byte, 4 dummy bytes, then 8 bytes,
// one byte read back per byte written. Those 8 reads answer cfg.unique_id (16 hex digits).
//
// Time: the chip's clock is rp2040js's simulation clock (125 MHz). While the core sleeps
// (WFE/WFI), or spins on a peripheral (the same load of the TIMER or an I2C controller again
// within SPIN_CYCLES: a busy-wait for a deadline or for the bus), its clock jumps to its next
// alarm (at most SPIN_MAX_NS ahead when spinning), as the instructions of the wait would have
// taken it there; a bus wait ends exactly when the byte completes, a deadline a few
// SPIN_MAX_NS late (a loop may load the timer three times a turn). Real time (default): only as far as the wall clock has gone, so an idle
// board costs no CPU and never runs ahead of real time. Fast: at once while the firmware
// samples (an I2C transaction in the last SAMPLING_NS), else at real time, so a board
// waiting for its host's next command does not run its scene ahead; the chip holds while
// Python says 'P' 1 (no host, or the host is not reading). cfg.spin_skip false
// ($TACTILE_PICO_SPIN=0) turns the spin rule off.

import fs from 'node:fs';
import net from 'node:net';
import { createRequire } from 'node:module';
import path from 'node:path';

const cfg = JSON.parse(process.argv[2]);
const require = createRequire(path.join(cfg.node_modules, 'noop.js'));
const { Simulator, ConsoleLogger, LogLevel, USBCDC } = require('rp2040js');
const { decodeBlock } = require('uf2');

const FLASH_SIZE = 2 * 1024 * 1024;
const FLASH_BASE = 0x10000000;
const READ_AHEAD = 16;
const BKPT_ERASE = 0xe1;
const BKPT_PROGRAM = 0xe2;
const OUT = 3;
const REPLY = 4;
const SLICE_MS = 10; // run this long between looks at the pipe from Python
const TIME_EVERY_NS = 1e6; // report the chip's time at least this often
// A load repeated this soon by the same instruction is a busy-wait: on the TIMER (a delay
// loop), and on an I2C controller when it also reads the same value (pico-sdk's wait for a
// byte, its timeout check included, takes 67 cycles a turn; a status that changes is work).
const SPIN_CYCLES = { timer: 64, i2c: 100 };
const SPIN_MAX_NS = 5e3;
const SAMPLING_NS = 10e6; // fast: I2C this recently means the firmware is sampling
const TIMER_BASE = 0x40054;

// --- the pipes ----------------------------------------------------------------------------
function send(type, payload = Buffer.alloc(0)) {
  const head = Buffer.from([type.charCodeAt(0), payload.length & 0xff, payload.length >> 8]);
  fs.writeSync(OUT, Buffer.concat([head, payload]));
}

function readReply(n) {
  const buf = Buffer.alloc(n);
  let got = 0;
  while (got < n) {
    const k = fs.readSync(REPLY, buf, got, n - got, null);
    if (k === 0) process.exit(0); // Python has gone
    got += k;
  }
  return buf;
}

function timeBytes(nanos) {
  const b = Buffer.alloc(8);
  b.writeBigUInt64LE(BigInt(Math.round(nanos))); // the chip's time in ns
  return b;
}

// --- boot ROM and flash ---------------------------------------------------------------------
function patchedRom() {
  const rom = fs.readFileSync(cfg.bootrom);
  const table = rom.readUInt16LE(0x14);
  const entry = {};
  for (let p = table; rom.readUInt16LE(p) !== 0; p += 4) {
    const code = rom.readUInt16LE(p);
    entry[String.fromCharCode(code & 0xff, code >> 8)] = rom.readUInt16LE(p + 2) & ~1;
  }
  if (entry.RE === undefined || entry.RP === undefined) {
    throw new Error(`${cfg.bootrom}: no flash_range_erase/program in the ROM's function table`);
  }
  rom.writeUInt16LE(0xbe00 | BKPT_ERASE, entry.RE);
  rom.writeUInt16LE(0xbe00 | BKPT_PROGRAM, entry.RP);
  return new Uint32Array(rom.buffer.slice(rom.byteOffset, rom.byteOffset + rom.length));
}

function openFlash() {
  if (!fs.existsSync(cfg.flash)) {
    const image = new Uint8Array(FLASH_SIZE).fill(0xff);
    const uf2 = fs.readFileSync(cfg.image);
    for (let at = 0; at + 512 <= uf2.length; at += 512) {
      const block = decodeBlock(uf2.subarray(at, at + 512));
      image.set(block.payload, block.flashAddress - FLASH_BASE);
    }
    fs.writeFileSync(cfg.flash + '.tmp', image);
    fs.renameSync(cfg.flash + '.tmp', cfg.flash);
  }
  const fd = fs.openSync(cfg.flash, 'r+');
  const bytes = new Uint8Array(FLASH_SIZE);
  if (fs.readSync(fd, bytes, 0, FLASH_SIZE, 0) !== FLASH_SIZE) {
    throw new Error(`${cfg.flash}: not a 2 MB flash image`);
  }
  return { fd, bytes };
}

const ROM = patchedRom();
const FLASH = openFlash();
const JOURNAL = cfg.flash_journal ? fs.openSync(cfg.flash_journal, 'a') : null;

// --- the chip --------------------------------------------------------------------------------
let sim, mcu, cdc;
let resetPending = false;
let hold = cfg.fast; // fast: no host yet
let pendingOut = []; // the chip's armed USB OUT buffers, answered when the host has bytes
const hostBytes = [];
let lastTimeNs = -TIME_EVERY_NS;
let spinning = false;

function boot() {
  sim = new Simulator();
  mcu = sim.rp2040;
  mcu.logger = new ConsoleLogger(LogLevel.Error);
  mcu.loadBootrom(ROM);
  mcu.flash.set(FLASH.bytes);
  mcu.onBreak = onBreak;
  mcu.peripherals[0x40058].onWatchdogTrigger = () => { // (the watchdog is not a property)
    resetPending = true;
  };
  wireUsb();
  if (cfg.unique_id) wireUniqueId(Buffer.from(cfg.unique_id, 'hex'));
  mcu.i2c.forEach(wireI2c);
  if (cfg.spin_skip !== false) {
    watchSpin(mcu.peripherals[TIMER_BASE], 'timer');
    mcu.i2c.forEach((i2c) => watchSpin(i2c, 'i2c'));
  }
  lastTimeNs = -TIME_EVERY_NS;
  mcu.core.PC = FLASH_BASE;
  pendingOut = [];
}

function onBreak(code) {
  const core = mcu.core;
  const r = core.registers;
  if (code === BKPT_ERASE) {
    const [at, n] = [r[0], r[1]];
    mcu.flash.fill(0xff, at, at + n);
    persist(at, n);
  } else if (code === BKPT_PROGRAM) {
    const [at, src, n] = [r[0], r[1], r[2]];
    for (let i = 0; i < n; i++) mcu.flash[at + i] &= mcu.readUint8(src + i);
    persist(at, n);
  } else {
    send('E', Buffer.from(`the chip stopped at a breakpoint (${code}) at ${(core.PC - 2).toString(16)}`));
    process.exit(3);
  }
  core.PC = r[14] & ~1; // return from the ROM routine
}

function persist(at, n) {
  FLASH.bytes.set(mcu.flash.subarray(at, at + n), at);
  fs.writeSync(FLASH.fd, mcu.flash, at, n, at);
  if (JOURNAL !== null) {
    const head = Buffer.alloc(8);
    head.writeUInt32LE(at, 0);
    head.writeUInt32LE(n, 4);
    fs.writeSync(JOURNAL, Buffer.concat([head, mcu.flash.subarray(at, at + n)]));
  }
}

function wireUniqueId(uid) {
  const SS_CTRL = 0x0c; // IO_QSPI GPIO_QSPI_SS_CTRL: OUTOVER (bits 8-9) 2 drives CS low
  const DR0 = 0x60;
  const RUID = 0x4b;
  const qspi = mcu.peripherals[0x40018]; // (unimplemented by rp2040js: writes only warn)
  const ssi = mcu.peripherals[0x18000];
  let at = -1; // bytes of the command since chip select went low; -1: not selected
  let ruid = false;
  const qspiWrite = qspi.writeUint32.bind(qspi);
  qspi.writeUint32 = (offset, value) => {
    if (offset === SS_CTRL) {
      at = ((value >>> 8) & 3) === 2 ? 0 : -1;
      ruid = false;
    }
    qspiWrite(offset, value);
  };
  const ssiWrite = ssi.writeUint32.bind(ssi);
  ssi.writeUint32 = (offset, value) => {
    ssiWrite(offset, value);
    if (offset !== DR0 || at < 0) return;
    if (at === 0) ruid = value === RUID;
    if (ruid) ssi.dr0 = at >= 5 && at < 5 + uid.length ? uid[at - 5] : 0;
    at += 1;
  };
}

function wireUsb() {
  cdc = new USBCDC(mcu.usbCtrl);
  cdc.onDeviceConnected = () => send('C');
  cdc.onSerialData = (data) => send('U', Buffer.from(data));
  // rp2040js answers every armed OUT buffer at once, empty when the host has nothing: the
  // chip then takes a USB interrupt every 10 us. A host answers when it has data.
  mcu.usbCtrl.onEndpointRead = (endpoint, size) => {
    if (endpoint !== cdc.outEndpoint) return;
    pendingOut.push(size);
    feedUsb();
  };
}

function feedUsb() {
  while (hostBytes.length && pendingOut.length) {
    const size = pendingOut.shift();
    const chunk = Uint8Array.from(hostBytes.splice(0, size));
    mcu.usbCtrl.endpointReadDone(cdc.outEndpoint, chunk);
  }
}

// A load from `peripheral` by an instruction (keyed by its address) that made the same load
// within SPIN_CYCLES[kind] twice before in a row (a loop, not a function called twice), each
// time with the same value for an I2C controller, marks a busy-wait: see "Time" above.
function watchSpin(peripheral, kind) {
  const read = peripheral.readUint32.bind(peripheral);
  const limit = SPIN_CYCLES[kind];
  const last = new Map(); // instruction address -> [cycle count, value, repeats in a row]
  peripheral.readUint32 = (offset) => {
    const core = mcu.core;
    const value = read(offset);
    const seen = last.get(core.PC);
    let repeats = 0;
    if (seen && core.cycles - seen[0] <= limit && (kind === 'timer' || seen[1] === value)) {
      repeats = seen[2] + 1;
      if (repeats >= 2) spinning = true;
    }
    last.set(core.PC, [core.cycles, value, repeats]);
    return value;
  };
}

// --- I2C: transactions answered by Python ------------------------------------------------------
function wireI2c(i2c, bus) {
  let txn = null;
  const approved = new Map(); // address -> the chip's time (ns) until which it ACKs, Python said
  const bitNs = () => ((i2c.sclHighPeriod + i2c.sclLowPeriod) * 1e9) / mcu.clkSys;
  const later = (bits, done) => {
    if (!cfg.bus_time) return done();
    const alarm = mcu.clock.createAlarm(done);
    alarm.schedule(bits * bitNs());
  };
  const ask = (kind, addr, extra, n) => {
    send(kind, Buffer.concat([Buffer.from([bus, addr]), timeBytes(mcu.clock.nanos), extra]));
    const reply = readReply(n);
    approved.set(addr, reply[0] === 0 ? Number(reply.readBigUInt64LE(1)) : -1);
    return reply;
  };
  const flushWrite = () => {
    if (txn && txn.ack && !txn.read && txn.written.length) {
      const head = Buffer.from([bus, txn.addr]);
      send('W', Buffer.concat([head, timeBytes(mcu.clock.nanos), Buffer.from(txn.written)]));
    }
  };
  i2c.onStart = () => later(1, () => i2c.completeStart());
  i2c.onConnect = (addr, mode) => {
    lastI2cNs = mcu.clock.nanos;
    if (txn && addr !== txn.addr) {
      flushWrite(); // (a repeated start to another device: the write was its own transaction)
      txn = null;
    }
    let ack;
    if (mode === 1) {
      // A read: asked for once, with the bytes written before the repeated start.
      const written = Buffer.from(txn ? txn.written : []);
      const reply = ask('R', addr, written, 9 + READ_AHEAD);
      ack = reply[0] === 0;
      txn = { addr, ack, written: [], read: reply.subarray(9), at: 0 };
    } else if (!txn) {
      // A write's address phase: answered here while Python's last answer holds, else asked.
      ack = (approved.get(addr) ?? -1) > mcu.clock.nanos || ask('A', addr, Buffer.alloc(0), 9)[0] === 0;
      txn = { addr, ack, written: [], read: null, at: 0 };
    } else {
      ack = txn.ack;
    }
    later(9, () => i2c.completeConnect(ack));
  };
  i2c.onWriteByte = (value) => {
    txn.written.push(value);
    later(9, () => i2c.completeWrite(true));
  };
  i2c.onReadByte = () => {
    const value = txn.at < txn.read.length ? txn.read[txn.at] : 0xff;
    txn.at += 1;
    later(9, () => i2c.completeRead(value));
  };
  i2c.onStop = () => {
    flushWrite();
    txn = null;
    later(1, () => i2c.completeStop());
  };
}

// --- the pipe from Python ----------------------------------------------------------------------
let inbox = Buffer.alloc(0);
const input = new net.Socket({ fd: 5, readable: true, writable: false });
input.on('data', (chunk) => {
  inbox = Buffer.concat([inbox, chunk]);
  while (inbox.length >= 3) {
    const n = inbox.readUInt16LE(1);
    if (inbox.length < 3 + n) break;
    const type = String.fromCharCode(inbox[0]);
    const payload = inbox.subarray(3, 3 + n);
    inbox = inbox.subarray(3 + n);
    if (type === 'H') {
      for (const b of payload) hostBytes.push(b);
      feedUsb();
    } else if (type === 'P') {
      hold = payload[0] !== 0;
    } else if (type === 'Q') {
      process.exit(0);
    }
  }
});
input.on('end', () => process.exit(0));

// --- the run -----------------------------------------------------------------------------------
// Pacing: the chip's time may not pass the wall clock's since the anchor (real time: the
// start, or a reset; fast: the moment the chip last stopped sampling, see "Time" above).
let anchorWall = performance.now();
let anchorSim = 0;
let lastI2cNs = -Infinity; // the chip's time of its latest I2C transaction

function slice() {
  if (hold) {
    if (cfg.fast) {
      anchorWall = performance.now(); // held time does not pass for the chip
      anchorSim = mcu.clock.nanos;
    }
    return setTimeout(slice, 2);
  }
  const core = mcu.core;
  const clock = mcu.clock;
  const cycleNs = 1e9 / mcu.clkSys;
  const end = performance.now() + SLICE_MS;
  let idleMs = 0;
  while (idleMs === 0 && performance.now() < end) {
    for (let i = 0; i < 2000; i++) {
      if (core.waiting || spinning) {
        let step = clock.nanosToNextAlarm;
        if (spinning) {
          spinning = false;
          step = step > 0 ? Math.min(step, SPIN_MAX_NS) : SPIN_MAX_NS;
        }
        if (cfg.fast && clock.nanos - lastI2cNs <= SAMPLING_NS) {
          anchorWall = performance.now(); // sampling: between samples time skips at once
          anchorSim = clock.nanos;
        } else {
          const ahead = clock.nanos - anchorSim - (performance.now() - anchorWall) * 1e6;
          if (ahead >= 0) {
            idleMs = Math.min(5, Math.max(1, ahead / 1e6));
            break;
          }
          step = step > 0 ? Math.min(step, -ahead) : -ahead;
        }
        if (step <= 0) {
          idleMs = 1; // nothing scheduled: only the host can wake it
          break;
        }
        clock.tick(step);
      } else {
        clock.tick(core.executeInstruction() * cycleNs);
      }
      if (resetPending) break;
    }
    if (resetPending) {
      resetPending = false;
      anchorWall = performance.now(); // the new chip's clock starts at 0
      anchorSim = 0;
      lastI2cNs = -Infinity;
      boot();
      send('X');
      return setImmediate(slice);
    }
  }
  if (clock.nanos - lastTimeNs >= TIME_EVERY_NS) {
    lastTimeNs = clock.nanos;
    send('T', timeBytes(clock.nanos));
  }
  if (idleMs > 0) return setTimeout(slice, idleMs);
  setImmediate(slice);
}

process.on('uncaughtException', (err) => {
  try {
    send('E', Buffer.from(String(err && err.message ? err.message : err)));
  } finally {
    process.exit(3);
  }
});

boot();
slice();
