//! Pass/fail checks of the scan report against issue 28's targets: each check names its
//! Done-when item, its target and the measured value; the report shows them as table cells and
//! sums them up per item.

use std::collections::BTreeMap;

use serde_json::{Value, json};

/// One measured value against one target.
#[derive(Clone, Debug)]
pub(crate) struct Check {
    /// The Done-when item (a short name, the same for every case of the item).
    pub(crate) item: &'static str,
    /// The target as text (`≤ 0.15`, `0.75–1.25`, …).
    pub(crate) target: String,
    /// The measured value (units as the item says).
    pub(crate) value: f64,
    /// The value as the table shows it.
    pub(crate) text: String,
    pub(crate) pass: bool,
}

impl Check {
    /// `value` ≤ `limit`; `text` shows the value. NaN fails.
    pub(crate) fn at_most(item: &'static str, value: f64, limit: f64, text: String) -> Self {
        Self {
            item,
            target: format!("≤ {}", short(limit)),
            value,
            text,
            pass: value <= limit,
        }
    }

    /// `value` ≥ `limit`; `text` shows the value. NaN fails.
    pub(crate) fn at_least(item: &'static str, value: f64, limit: f64, text: String) -> Self {
        Self {
            item,
            target: format!("≥ {}", short(limit)),
            value,
            text,
            pass: value >= limit,
        }
    }

    /// `lo` ≤ `value` ≤ `hi`; `text` shows the value. NaN fails.
    pub(crate) fn between(
        item: &'static str,
        value: f64,
        (lo, hi): (f64, f64),
        text: String,
    ) -> Self {
        Self {
            item,
            target: format!("{}–{}", short(lo), short(hi)),
            value,
            text,
            pass: (lo..=hi).contains(&value),
        }
    }

    /// The table cell: the value and ✓ or ✗.
    pub(crate) fn cell(&self) -> String {
        format!("{} {}", self.text, if self.pass { "✓" } else { "✗" })
    }

    /// The check as JSON: `item`, `target`, `value`, `pass`.
    pub(crate) fn to_json(&self) -> Value {
        json!({ "item": self.item, "target": self.target, "value": self.value, "pass": self.pass })
    }
}

/// A number for a target: up to four significant digits, no trailing zeros.
fn short(x: f64) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s.is_empty() {
        "0".into()
    } else {
        s.to_owned()
    }
}

/// The checks of many cases as JSON (shape: checks).
pub(crate) fn checks_json(checks: &[Check]) -> Value {
    Value::Array(checks.iter().map(Check::to_json).collect())
}

/// One item's checks summed up: the target, the cases passing, all cases, the lowest and the
/// highest value.
type Tally = (String, usize, usize, f64, f64);

/// The summary table over report rows (each with `group` and `checks`, [`checks_json`]): per
/// group and item, the target, the cases passing of all, and the range of the values.
pub(crate) fn summary(rows: &[Value]) -> String {
    let mut items: BTreeMap<(String, String), Tally> = BTreeMap::new();
    for row in rows {
        let group = row["group"].as_str().unwrap_or("?").to_owned();
        for c in row["checks"].as_array().into_iter().flatten() {
            let key = (group.clone(), c["item"].as_str().unwrap_or("?").to_owned());
            let v = c["value"].as_f64().unwrap_or(f64::NAN);
            let e = items.entry(key).or_insert_with(|| {
                let target = c["target"].as_str().unwrap_or("").to_owned();
                (target, 0, 0, f64::INFINITY, f64::NEG_INFINITY)
            });
            e.1 += usize::from(c["pass"].as_bool().unwrap_or(false));
            e.2 += 1;
            e.3 = e.3.min(v);
            e.4 = e.4.max(v);
        }
    }
    let mut md = String::from(
        "## Summary against issue 28's Done-when items\n\n| group | item | target | cases passing | values (lowest – highest) | verdict |\n|---|---|---|---|---|---|\n",
    );
    for ((group, item), (target, pass, all, lo, hi)) in &items {
        md.push_str(&format!(
            "| {group} | {item} | {target} | {pass} / {all} | {} – {} | {} |\n",
            short_value(*lo),
            short_value(*hi),
            if pass == all { "PASS" } else { "FAIL" }
        ));
    }
    md
}

/// A value for the summary: three significant digits.
fn short_value(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (x.fract() == 0.0 && x.abs() < 1e6) {
        format!("{x}")
    } else if x.abs() >= 1e-2 && x.abs() < 1e4 {
        format!("{x:.3}")
    } else {
        format!("{x:.2e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_pass_fail_and_sum_up() {
        let a = Check::at_most("cv", 0.1, 0.12, "0.100".into());
        let b = Check::at_most("cv", f64::NAN, 0.12, "NaN".into());
        let c = Check::between("count", 1.3, (0.75, 1.25), "1.30×".into());
        assert!(a.pass && !b.pass && !c.pass);
        assert_eq!(c.target, "0.75–1.25");
        assert_eq!(a.cell(), "0.100 ✓");
        let rows = vec![
            json!({"group": "g", "checks": checks_json(&[a.clone(), c])}),
            json!({"group": "g", "checks": checks_json(&[a])}),
        ];
        let md = summary(&rows);
        assert!(
            md.contains("| g | cv | ≤ 0.12 | 2 / 2 | 0.100 – 0.100 | PASS |"),
            "{md}"
        );
        assert!(md.contains("| g | count | 0.75–1.25 | 0 / 1 |"), "{md}");
    }
}
