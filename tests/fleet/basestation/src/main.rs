//! A base station as the fleet's: decodes every datagram with prost on its exact length
//! (`&buf[..len]`), prints what it got, and sends drive commands while told to.
//!
//! stdin: `RELAY <port>` (where to send), `DRIVE on|off`, `QUIT`. stdout, one line each:
//! `PORT <port>` once bound; `OK <member> <debug>` or `ERR <prost error>` per datagram;
//! `SENT <count>` (drive commands sent) on QUIT.

mod envelope;

use std::io::{BufRead, Write};
use std::net::UdpSocket;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use envelope::pb_envelope::Payload;
use envelope::{DrivingBoardMotorMessage, PbEnvelope};
use prost::Message;

const DRIVE_PERIOD: Duration = Duration::from_millis(50);
const DRIVE_TIMEOUT_MS: u32 = 300;

fn main() {
    let socket = UdpSocket::bind("127.0.0.1:0").expect("bind");
    socket.set_read_timeout(Some(Duration::from_millis(5))).expect("timeout");
    let out = std::io::stdout();
    writeln!(out.lock(), "PORT {}", socket.local_addr().unwrap().port()).unwrap();

    let (lines, commands) = mpsc::channel::<String>();
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let sent = match line {
                Ok(line) => lines.send(line).is_ok(),
                Err(_) => false,
            };
            if !sent {
                break;
            }
        }
    });

    let mut relay: Option<String> = None;
    let mut driving = false;
    let mut sent = 0u64;
    let mut next = Instant::now();
    let mut buf = [0u8; 2048];
    loop {
        while let Ok(line) = commands.try_recv() {
            let words: Vec<&str> = line.split_whitespace().collect();
            match words.as_slice() {
                ["RELAY", port] => relay = Some(format!("127.0.0.1:{port}")),
                ["DRIVE", "on"] => driving = true,
                ["DRIVE", "off"] => driving = false,
                ["QUIT"] => {
                    writeln!(out.lock(), "SENT {sent}").unwrap();
                    return;
                }
                _ => panic!("unknown command {line:?}"),
            }
        }
        if driving && Instant::now() >= next {
            if let Some(to) = &relay {
                let command = PbEnvelope {
                    payload: Some(Payload::DriveMotor(DrivingBoardMotorMessage {
                        distance_to_go: 1.5,
                        turning_radius: 0.0,
                    })),
                    timeout: DRIVE_TIMEOUT_MS,
                };
                socket.send_to(&command.encode_to_vec(), to).expect("send");
                sent += 1;
            }
            next = Instant::now() + DRIVE_PERIOD;
        }
        match socket.recv_from(&mut buf) {
            Ok((len, _)) => {
                let line = match PbEnvelope::decode(&buf[..len]) {
                    Ok(envelope) => match envelope.payload {
                        Some(payload) => {
                            let shown = format!("{payload:?}");
                            let member = shown.split('(').next().unwrap_or("").to_string();
                            format!("OK {member} {}", shown.replace('\n', " "))
                        }
                        None => "OK none".to_string(),
                    },
                    Err(error) => format!("ERR {error}"),
                };
                writeln!(out.lock(), "{line}").unwrap();
            }
            Err(error)
                if error.kind() == std::io::ErrorKind::WouldBlock
                    || error.kind() == std::io::ErrorKind::TimedOut => {}
            Err(error) => panic!("recv: {error}"),
        }
    }
}
