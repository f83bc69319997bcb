//! Whether a bag's header stamps can be trusted as one clock: each stream's stamps are
//! compared with the times the recorder logged its messages.
//!
//! A header stamp is the better time where every stream's stamps run on the recorder's
//! clock (it leaves out transport delay); it is wrong where they do not: commands stamped
//! on a simulation clock beside wheels on the wall clock, one stream skewed by seconds,
//! stamps that jump back an hour or forward to 2038, half a stream unstamped (placed at
//! its log time) beside stamps far from it. Log times are one clock by construction.

use std::collections::BTreeMap;

/// Largest offset between one stream's stamps and log times that may differ from
/// another stream's, or within one stream, s. Transport delay and a recorder's queue
/// are milliseconds to tenths of a second; a clock that differs by more is another clock.
pub const CLOCK_TOLERANCE_S: f64 = 1.0;

/// Each stream's messages as (log time, time placed at), ns since the epoch, by topic.
pub type StreamTimes = BTreeMap<String, Vec<(i64, i64)>>;

fn median(mut v: Vec<i64>) -> i64 {
    v.sort_unstable();
    v[v.len() / 2]
}

fn s_of(ns: i64) -> f64 {
    ns as f64 * 1e-9
}

/// Why the streams' stamps are not one clock, in words naming the topics; `None` when
/// every stream's stamp - log offset lies within [`CLOCK_TOLERANCE_S`] of every other's.
///
/// Topics whose name ends in `tf_static` are left out: a static transform is stamped
/// when it was first published, which may be long before the recording.
pub fn disagreement(streams: &StreamTimes) -> Option<String> {
    let tol = (CLOCK_TOLERANCE_S * 1e9) as i64;
    let mut medians: Vec<(&str, i64)> = vec![];
    for (topic, times) in streams {
        if times.is_empty() || topic.ends_with("tf_static") {
            continue;
        }
        let offsets: Vec<i64> = times
            .iter()
            .map(|(log, at)| at.saturating_sub(*log))
            .collect();
        let m = median(offsets.clone());
        let off: Vec<usize> = (0..offsets.len())
            .filter(|&k| offsets[k].saturating_sub(m).abs() > tol)
            .collect();
        if let Some(&first) = off.first() {
            return Some(format!(
                "topic `{topic}`: {} of its {} messages are stamped more than {CLOCK_TOLERANCE_S} s from where the others' stamps put their log times (the first, message {}, {:+.3} s from its log time where the median is {:+.3} s): a clock that jumps, or unstamped messages among stamped ones",
                off.len(),
                offsets.len(),
                first + 1,
                s_of(offsets[first]),
                s_of(m)
            ));
        }
        medians.push((topic, m));
    }
    let lo = medians.iter().min_by_key(|(_, m)| *m)?;
    let hi = medians.iter().max_by_key(|(_, m)| *m)?;
    (hi.1.saturating_sub(lo.1) > tol).then(|| {
        format!(
            "the stamps of `{}` run {:+.3} s from their log times and those of `{}` {:+.3} s: the streams' clocks disagree by more than {CLOCK_TOLERANCE_S} s (a simulation clock beside the wall clock, or a skewed one)",
            hi.0,
            s_of(hi.1),
            lo.0,
            s_of(lo.1)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: i64 = 1_000_000_000;

    fn stream(offset_ns: impl Fn(i64) -> i64) -> Vec<(i64, i64)> {
        (0..100)
            .map(|k| {
                let log = 1_700_000_000 * S + k * S / 10;
                (log, log + offset_ns(k))
            })
            .collect()
    }

    #[test]
    fn stamps_a_few_milliseconds_before_their_log_times_agree() {
        let mut s = StreamTimes::new();
        s.insert("/joint_states".into(), stream(|k| -(2 + k % 3) * S / 1000));
        s.insert("/cmd_vel".into(), stream(|_| -S / 100));
        s.insert("/tf_static".into(), stream(|_| -3600 * S));
        assert_eq!(disagreement(&s), None);
    }

    #[test]
    fn a_simulation_clock_beside_the_wall_clock_disagrees_naming_both() {
        let mut s = StreamTimes::new();
        s.insert("/joint_states".into(), stream(|_| 0));
        s.insert("/cmd_vel".into(), stream(|_| -1_700_000_000 * S));
        let why = disagreement(&s).unwrap();
        assert!(why.contains("`/joint_states` run +0.000 s"), "{why}");
        assert!(why.contains("`/cmd_vel` -1700000000.000 s"), "{why}");
    }

    #[test]
    fn a_skew_of_seconds_a_jump_back_or_one_stamp_in_2038_are_found() {
        let mut skew = StreamTimes::new();
        skew.insert("/a".into(), stream(|_| 0));
        skew.insert("/b".into(), stream(|_| 5 * S));
        assert!(disagreement(&skew).is_some());
        let mut back = StreamTimes::new();
        back.insert("/a".into(), stream(|k| if k >= 60 { -3600 * S } else { 0 }));
        let why = disagreement(&back).unwrap();
        assert!(why.contains("40 of its 100 messages"), "{why}");
        assert!(why.contains("message 61"), "{why}");
        let mut y2038 = StreamTimes::new();
        y2038.insert(
            "/a".into(),
            stream(|k| if k == 7 { 447_000_000 * S } else { 0 }),
        );
        assert!(disagreement(&y2038).unwrap().contains("1 of its 100"));
    }

    #[test]
    fn half_a_stream_unstamped_beside_stamps_far_from_log_time_disagrees() {
        // Unstamped messages are placed at their log time (offset 0).
        let mut s = StreamTimes::new();
        s.insert("/a".into(), stream(|k| if k % 2 == 0 { 0 } else { 30 * S }));
        assert!(disagreement(&s).unwrap().contains("50 of its 100"));
    }
}
