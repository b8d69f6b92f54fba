//! Decoding `sensor_msgs/Imu` by hand: the layout is fixed, so no ROS install and no
//! message-definition parser is needed.
//!
//! Fields in order: header, orientation (4 f64), orientation_covariance (9 f64),
//! angular_velocity (3 f64, rad/s), angular_velocity_covariance (9 f64),
//! linear_acceleration (3 f64, m/s²), linear_acceleration_covariance (9 f64).
//! - ROS 1: header = uint32 seq, uint32 sec, uint32 nsec, string frame_id (uint32 length,
//!   no terminator); little-endian, no padding.
//! - ROS 2 (CDR): a 4-byte encapsulation header (`00 01` little-endian, `00 00` big-endian),
//!   then header = int32 sec, uint32 nanosec, string frame_id (uint32 length including the
//!   terminating NUL); each f64 is aligned to 8 bytes from the start of the payload.

/// One decoded IMU message: header stamp (ns since the epoch), angular velocity (rad/s)
/// and linear acceleration (m/s²).
///
/// ```
/// use imunoise::logs::imu_msg::{ImuSample, decode_cdr, encode_cdr};
/// let (gyro, acc) = ([1e-3, 0.0, -1e-3], [0.0, 0.0, 9.81]);
/// let s = ImuSample { stamp_ns: 1_700_000_000_250_000_000, gyro, acc };
/// // a ROS 2 message carries the stamp as seconds and nanoseconds
/// let msg = encode_cdr(&s, "imu_link");
/// assert_eq!(msg[4..8], 1_700_000_000i32.to_le_bytes());
/// assert_eq!(msg[8..12], 250_000_000u32.to_le_bytes());
/// assert_eq!(decode_cdr(&msg).unwrap(), s);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuSample {
    /// Header stamp in nanoseconds.
    pub stamp_ns: i64,
    /// angular_velocity x, y, z (rad/s).
    pub gyro: [f64; 3],
    /// linear_acceleration x, y, z (m/s²).
    pub acc: [f64; 3],
}

/// The ROS 1 type name.
pub const ROS1_IMU: &str = "sensor_msgs/Imu";
/// The ROS 2 type name.
pub const ROS2_IMU: &str = "sensor_msgs/msg/Imu";

/// True for the type names of `sensor_msgs/Imu` (ROS 1 and ROS 2 spellings).
///
/// ```
/// assert!(imunoise::logs::imu_msg::is_imu_type("sensor_msgs/msg/Imu"));
/// assert!(!imunoise::logs::imu_msg::is_imu_type("sensor_msgs/msg/Image"));
/// ```
pub fn is_imu_type(t: &str) -> bool {
    t == ROS1_IMU || t == ROS2_IMU
}

fn f64_at(b: &[u8], off: usize, le: bool) -> f64 {
    let a: [u8; 8] = b[off..off + 8].try_into().expect("8 bytes");
    if le {
        f64::from_le_bytes(a)
    } else {
        f64::from_be_bytes(a)
    }
}

fn u32_at(b: &[u8], off: usize, le: bool) -> u32 {
    let a: [u8; 4] = b[off..off + 4].try_into().expect("4 bytes");
    if le {
        u32::from_le_bytes(a)
    } else {
        u32::from_be_bytes(a)
    }
}

/// Size of the 37 f64 after the header.
const BODY: usize = 37 * 8;

/// Decodes a ROS 1 serialized `sensor_msgs/Imu`; `Err` says what is wrong.
///
/// ```
/// use imunoise::logs::imu_msg::{decode_ros1, encode_ros1, ImuSample};
/// let s = ImuSample { stamp_ns: 1_500_000_000, gyro: [0.1, 0.2, 0.3], acc: [0.0, 0.0, 9.81] };
/// assert_eq!(decode_ros1(&encode_ros1(&s, 7, "imu")).unwrap(), s);
/// ```
pub fn decode_ros1(b: &[u8]) -> Result<ImuSample, String> {
    if b.len() < 16 {
        return Err(format!(
            "{} bytes, too short for a ROS 1 Imu header",
            b.len()
        ));
    }
    let sec = u32_at(b, 4, true) as i64;
    let nsec = u32_at(b, 8, true) as i64;
    let len = u32_at(b, 12, true) as usize;
    let start = 16usize
        .checked_add(len)
        .filter(|&s| s.checked_add(BODY) == Some(b.len()))
        .ok_or_else(|| {
            format!(
                "{} bytes, but a ROS 1 Imu with a {len}-byte frame_id has {}",
                b.len(),
                16usize.saturating_add(len).saturating_add(BODY)
            )
        })?;
    let g = start + 13 * 8;
    let a = g + 12 * 8;
    Ok(ImuSample {
        stamp_ns: sec * 1_000_000_000 + nsec,
        gyro: [
            f64_at(b, g, true),
            f64_at(b, g + 8, true),
            f64_at(b, g + 16, true),
        ],
        acc: [
            f64_at(b, a, true),
            f64_at(b, a + 8, true),
            f64_at(b, a + 16, true),
        ],
    })
}

/// Decodes a ROS 2 CDR serialized `sensor_msgs/msg/Imu` (little- or big-endian).
///
/// ```
/// use imunoise::logs::imu_msg::{decode_cdr, encode_cdr, ImuSample};
/// let s = ImuSample { stamp_ns: 1_500_000_000, gyro: [0.1, 0.2, 0.3], acc: [0.0, 0.0, 9.81] };
/// assert_eq!(decode_cdr(&encode_cdr(&s, "imu_link")).unwrap(), s);
/// ```
pub fn decode_cdr(b: &[u8]) -> Result<ImuSample, String> {
    if b.len() < 16 {
        return Err(format!("{} bytes, too short for a CDR Imu header", b.len()));
    }
    let le = match (b[0], b[1]) {
        (0, 1) | (0, 3) => true,
        (0, 0) | (0, 2) => false,
        (x, y) => return Err(format!("unknown CDR encapsulation {x:#04x} {y:#04x}")),
    };
    let p = &b[4..];
    let sec = u32_at(p, 0, le) as i32 as i64;
    let nsec = u32_at(p, 4, le) as i64;
    let len = u32_at(p, 8, le) as usize;
    let end = 12usize.checked_add(len).ok_or("bad frame_id length")?;
    let start = end.div_ceil(8) * 8;
    // Trailing padding bytes are allowed (some writers pad to 4 or 8).
    if start.checked_add(BODY).is_none_or(|e| e > p.len()) {
        return Err(format!(
            "{} bytes, but a CDR Imu with a {len}-byte frame_id needs {}",
            b.len(),
            4usize.saturating_add(start).saturating_add(BODY)
        ));
    }
    let g = start + 13 * 8;
    let a = g + 12 * 8;
    Ok(ImuSample {
        stamp_ns: sec * 1_000_000_000 + nsec,
        gyro: [
            f64_at(p, g, le),
            f64_at(p, g + 8, le),
            f64_at(p, g + 16, le),
        ],
        acc: [
            f64_at(p, a, le),
            f64_at(p, a + 8, le),
            f64_at(p, a + 16, le),
        ],
    })
}

fn body(s: &ImuSample) -> Vec<u8> {
    let mut v = Vec::with_capacity(BODY);
    let mut put = |x: f64| v.extend_from_slice(&x.to_le_bytes());
    for x in [0.0, 0.0, 0.0, 1.0] {
        put(x);
    }
    (0..9).for_each(|_| put(0.0));
    s.gyro.iter().for_each(|&x| put(x));
    (0..9).for_each(|_| put(0.0));
    s.acc.iter().for_each(|&x| put(x));
    (0..9).for_each(|_| put(0.0));
    v
}

/// Serializes a sample as a ROS 1 `sensor_msgs/Imu` (for writing test fixtures and
/// benchmarks); the covariances are zero and the orientation is the identity.
///
/// ```
/// use imunoise::logs::imu_msg::{ImuSample, decode_ros1, encode_ros1};
/// let s = ImuSample { stamp_ns: 3_000_000_007, gyro: [0.1, 0.2, 0.3], acc: [0.0, 0.0, 9.81] };
/// let msg = encode_ros1(&s, 42, "imu");
/// // seq, sec, nsec, then frame_id with its length; 37 f64 after the header
/// assert_eq!(msg[..4], 42u32.to_le_bytes());
/// assert_eq!(msg[4..8], 3u32.to_le_bytes());
/// assert_eq!(msg[8..12], 7u32.to_le_bytes());
/// assert_eq!(&msg[16..19], b"imu");
/// assert_eq!(msg.len(), 16 + 3 + 37 * 8);
/// assert_eq!(decode_ros1(&msg).unwrap(), s);
/// ```
pub fn encode_ros1(s: &ImuSample, seq: u32, frame_id: &str) -> Vec<u8> {
    let mut v = Vec::with_capacity(16 + frame_id.len() + BODY);
    v.extend_from_slice(&seq.to_le_bytes());
    v.extend_from_slice(&(s.stamp_ns.div_euclid(1_000_000_000) as u32).to_le_bytes());
    v.extend_from_slice(&(s.stamp_ns.rem_euclid(1_000_000_000) as u32).to_le_bytes());
    v.extend_from_slice(&(frame_id.len() as u32).to_le_bytes());
    v.extend_from_slice(frame_id.as_bytes());
    v.extend_from_slice(&body(s));
    v
}

/// Serializes a sample as a little-endian CDR `sensor_msgs/msg/Imu` (for writing test
/// fixtures and benchmarks).
///
/// ```
/// use imunoise::logs::imu_msg::{ImuSample, decode_cdr, encode_cdr};
/// let s = ImuSample { stamp_ns: 1_500_000_000, gyro: [0.1, 0.2, 0.3], acc: [0.0, 0.0, 9.81] };
/// let msg = encode_cdr(&s, "imu");
/// assert_eq!(msg[..4], [0, 1, 0, 0]); // little-endian CDR
/// // the frame_id's length counts its NUL; the f64 start 8-aligned after the 4-byte header
/// assert_eq!(msg[12..16], 4u32.to_le_bytes());
/// assert_eq!(&msg[16..20], b"imu\0");
/// assert_eq!(msg.len(), 4 + 16 + 37 * 8);
/// assert_eq!(decode_cdr(&msg).unwrap(), s);
/// ```
pub fn encode_cdr(s: &ImuSample, frame_id: &str) -> Vec<u8> {
    let mut v = vec![0u8, 1, 0, 0];
    v.extend_from_slice(&(s.stamp_ns.div_euclid(1_000_000_000) as i32).to_le_bytes());
    v.extend_from_slice(&(s.stamp_ns.rem_euclid(1_000_000_000) as u32).to_le_bytes());
    v.extend_from_slice(&(frame_id.len() as u32 + 1).to_le_bytes());
    v.extend_from_slice(frame_id.as_bytes());
    v.push(0);
    while !(v.len() - 4).is_multiple_of(8) {
        v.push(0);
    }
    v.extend_from_slice(&body(s));
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_rejects_bad_sizes() {
        let s = ImuSample {
            stamp_ns: 1_700_000_000_123_456_789,
            gyro: [1e-3, -2.5, 3.25],
            acc: [0.1, -0.2, 9.80665],
        };
        for frame in ["", "a", "imu_link", "1234567"] {
            assert_eq!(decode_cdr(&encode_cdr(&s, frame)).unwrap(), s);
            assert_eq!(decode_ros1(&encode_ros1(&s, 1, frame)).unwrap(), s);
        }
        let c = encode_cdr(&s, "imu");
        assert!(decode_cdr(&c[..c.len() - 1]).is_err());
        let r = encode_ros1(&s, 0, "imu");
        assert!(decode_ros1(&r[..r.len() - 1]).is_err());
        assert!(decode_ros1(&[0u8; 10]).is_err());
        // Big-endian CDR: swap every field by hand.
        let mut be = vec![0u8, 0, 0, 0];
        be.extend_from_slice(&((s.stamp_ns / 1_000_000_000) as i32).to_be_bytes());
        be.extend_from_slice(&((s.stamp_ns % 1_000_000_000) as u32).to_be_bytes());
        be.extend_from_slice(&4u32.to_be_bytes());
        be.extend_from_slice(b"imu\0");
        for k in 0..37 {
            let x = match k {
                13..=15 => s.gyro[k - 13],
                25..=27 => s.acc[k - 25],
                _ => 0.0,
            };
            be.extend_from_slice(&x.to_be_bytes());
        }
        assert_eq!(decode_cdr(&be).unwrap(), s);
    }
}
