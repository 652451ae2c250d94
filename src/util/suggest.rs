//! "Did you mean …?": the nearest of a set of names to a misspelt one, by edit distance. One
//! helper for every place a name is parsed (scheduler, order, tracer and other ids, command-line
//! flags and subcommands, TOML keys), so a typo gets the same hint wherever it is made.

/// Edit distance between `a` and `b` (insertions, deletions, substitutions and swaps of two
/// neighbours each cost 1), ignoring case and counting `-` and `_` as the same character:
/// `self-Scheduling` is 0 from `self_scheduling`.
pub fn distance(a: &str, b: &str) -> usize {
    let norm = |s: &str| -> Vec<char> {
        s.chars()
            .flat_map(char::to_lowercase)
            .map(|c| if c == '-' { '_' } else { c })
            .collect()
    };
    let (a, b) = (norm(a), norm(b));
    // Optimal string alignment over three rows: O(|a|·|b|) time, O(|b|) memory.
    let mut before: Vec<usize> = vec![0; b.len() + 1];
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for i in 1..=a.len() {
        cur[0] = i;
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut d = (prev[j] + 1).min(cur[j - 1] + 1).min(prev[j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d = d.min(before[j - 2] + 1);
            }
            cur[j] = d;
        }
        std::mem::swap(&mut before, &mut prev);
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// Longest name compared: a longer word is no typo of a name, and its distance to every
/// candidate would cost time for nothing (the command line takes 100 k-character values).
const MAX_WORD: usize = 64;

/// The candidate nearest to `word` when it is close enough to be a typo of it: within a third
/// of the longer name's length (at least 1), the first of equals in `candidates` order. `None`
/// for an exact match (nothing to suggest), an empty word or nothing close.
pub fn nearest<'a, I>(word: &str, candidates: I) -> Option<&'a str>
where
    I: IntoIterator<Item = &'a str>,
{
    let n = word.chars().count();
    if n == 0 || n > MAX_WORD {
        return None;
    }
    let mut best: Option<(usize, &'a str)> = None;
    for c in candidates {
        if c == word {
            return None;
        }
        let d = distance(word, c);
        let limit = (n.max(c.chars().count()) / 3).max(1);
        if d <= limit && best.is_none_or(|(b, _)| d < b) {
            best = Some((d, c));
        }
    }
    best.map(|(_, c)| c)
}

/// `, did you mean X?` for the nearest candidate ([`nearest`]), or an empty string: ready to
/// be spliced into a one-line error after the name that was not found.
pub fn did_you_mean<'a, I>(word: &str, candidates: I) -> String
where
    I: IntoIterator<Item = &'a str>,
{
    nearest(word, candidates).map_or(String::new(), |c| format!(", did you mean {c}?"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_counts_edits_and_ignores_case_and_dash_or_underscore() {
        assert_eq!(distance("", ""), 0);
        assert_eq!(distance("abc", ""), 3);
        assert_eq!(distance("kitten", "sitting"), 3);
        assert_eq!(distance("self_schedulng", "self_scheduling"), 1);
        assert_eq!(distance("slef_scheduling", "self_scheduling"), 1);
        assert_eq!(distance("Work-Stealing", "work_stealing"), 0);
        assert_eq!(distance("ünïcode", "unicode"), 2);
    }

    #[test]
    fn nearest_names_a_close_candidate_and_nothing_far() {
        let ids = ["static", "self_scheduling", "guided", "master"];
        assert_eq!(
            nearest("self_schedulng", ids.iter().copied()),
            Some("self_scheduling")
        );
        assert_eq!(nearest("Master", ids.iter().copied()), Some("master"));
        assert_eq!(nearest("gided", ids.iter().copied()), Some("guided"));
        assert_eq!(nearest("fastest", ids.iter().copied()), None);
        assert_eq!(nearest("master", ids.iter().copied()), None);
        assert_eq!(nearest("", ids.iter().copied()), None);
        assert_eq!(nearest(&"x".repeat(100_000), ids.iter().copied()), None);
        assert_eq!(
            did_you_mean("stati", ids.iter().copied()),
            ", did you mean static?"
        );
        assert_eq!(did_you_mean("optix", ["bvh", "brute"]), "");
    }
}
