//! `--frames`: which frames of a take, as a comma-separated list of frames (`388`) and ranges
//! (`0..100`, end excluded; `0..1590:10`, every tenth; `100..`, to the end of the take).

use std::fmt;

/// One item of a `--frames` list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Item {
    /// One frame.
    Frame(usize),
    /// `start..end:step`; `end` `None` runs to the end of the take.
    Range {
        start: usize,
        end: Option<usize>,
        step: usize,
    },
}

/// A parsed `--frames` value; [`FrameSelection::resolve`] turns it into frame numbers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameSelection(Vec<Item>);

impl fmt::Display for Item {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Item::Frame(n) => write!(f, "{n}"),
            Item::Range { start, end, step } => {
                write!(f, "{start}..")?;
                if let Some(end) = end {
                    write!(f, "{end}")?;
                }
                if step != 1 {
                    write!(f, ":{step}")?;
                }
                Ok(())
            }
        }
    }
}

/// Parses a `--frames` value (`0..100`, `0..1590:10`, `0,388,1122`, `100..`, or a mix).
pub fn parse_frames(text: &str) -> Result<FrameSelection, String> {
    let number = |s: &str, what: &str, item: &str| -> Result<usize, String> {
        s.trim().parse::<usize>().map_err(|_| {
            format!(
                "\"{item}\": {what} \"{}\" is not a frame number (0, 1, 2, ...)",
                s.trim()
            )
        })
    };
    let mut items = Vec::new();
    for item in text.split(',') {
        let item = item.trim();
        if item.is_empty() {
            return Err(format!(
                "\"{text}\" has an empty item: write frames (388) and ranges (0..100, 0..1590:10) separated by commas"
            ));
        }
        let Some((start, rest)) = item.split_once("..") else {
            items.push(Item::Frame(number(item, "frame", item)?));
            continue;
        };
        let (end, step) = match rest.split_once(':') {
            Some((end, step)) => (end, number(step, "step", item)?),
            None => (rest, 1),
        };
        if step == 0 {
            return Err(format!("\"{item}\": the step must be at least 1"));
        }
        let start = number(start, "start", item)?;
        let end = match end.trim() {
            "" => None,
            e if e.starts_with('=') => {
                return Err(format!(
                    "\"{item}\": ranges exclude their end (write {start}..{} for {start} to {} included)",
                    e[1..].trim().parse::<usize>().map_or("N+1".into(), |n| (n + 1).to_string()),
                    &e[1..]
                ))
            }
            e => Some(number(e, "end", item)?),
        };
        if end.is_some_and(|e| e <= start) {
            return Err(format!(
                "\"{item}\": the range is empty (its end is excluded and must exceed its start)"
            ));
        }
        items.push(Item::Range { start, end, step });
    }
    Ok(FrameSelection(items))
}

impl FrameSelection {
    /// Every frame of a take.
    pub fn all() -> Self {
        FrameSelection(vec![Item::Range {
            start: 0,
            end: None,
            step: 1,
        }])
    }

    /// The frames selected from a take of `count` frames, in increasing order, each once.
    /// A frame or range end beyond the take is an error naming the item.
    pub fn resolve(&self, count: usize) -> Result<Vec<usize>, String> {
        let mut frames = Vec::new();
        for item in &self.0 {
            let beyond = || {
                format!(
                    "--frames {item}: the take has {count} frames (0 to {})",
                    count.saturating_sub(1)
                )
            };
            match *item {
                Item::Frame(n) if n >= count => return Err(beyond()),
                Item::Frame(n) => frames.push(n),
                Item::Range { start, end, step } => {
                    let end = end.unwrap_or(count);
                    if end > count || start >= count {
                        return Err(beyond());
                    }
                    frames.extend((start..end).step_by(step));
                }
            }
        }
        frames.sort_unstable();
        frames.dedup();
        Ok(frames)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(text: &str, count: usize) -> Result<Vec<usize>, String> {
        parse_frames(text)?.resolve(count)
    }

    #[test]
    fn ranges_lists_and_steps() {
        assert_eq!(frames("0..5", 10).unwrap(), [0, 1, 2, 3, 4]);
        assert_eq!(frames("0..10:3", 10).unwrap(), [0, 3, 6, 9]);
        assert_eq!(frames("7..", 10).unwrap(), [7, 8, 9]);
        assert_eq!(frames("5..:2", 10).unwrap(), [5, 7, 9]);
        assert_eq!(frames("0,388,1122", 1590).unwrap(), [0, 388, 1122]);
        // Sorted and each once, whatever the order.
        assert_eq!(frames("9, 2..4, 3, 0", 10).unwrap(), [0, 2, 3, 9]);
        assert_eq!(frames("0..1590:10", 1590).unwrap().len(), 159);
        assert_eq!(FrameSelection::all().resolve(4).unwrap(), [0, 1, 2, 3]);
    }

    #[test]
    fn clear_errors() {
        let e = parse_frames("0..x").unwrap_err();
        assert!(
            e.contains("\"0..x\": end \"x\" is not a frame number"),
            "{e}"
        );
        let e = parse_frames("0..10:0").unwrap_err();
        assert!(e.contains("step must be at least 1"), "{e}");
        let e = parse_frames("5..5").unwrap_err();
        assert!(e.contains("the range is empty"), "{e}");
        let e = parse_frames("0..=9").unwrap_err();
        assert!(e.contains("write 0..10"), "{e}");
        let e = parse_frames("1,,2").unwrap_err();
        assert!(e.contains("empty item"), "{e}");
        let e = parse_frames("-1").unwrap_err();
        assert!(e.contains("frame \"-1\""), "{e}");
        let e = frames("0..2000", 1590).unwrap_err();
        assert!(
            e.contains("--frames 0..2000: the take has 1590 frames (0 to 1589)"),
            "{e}"
        );
        let e = frames("12", 10).unwrap_err();
        assert!(e.contains("--frames 12"), "{e}");
        let e = frames("10..", 10).unwrap_err();
        assert!(e.contains("--frames 10.."), "{e}");
    }
}
