//! `--shard I/N`: one of N parts of a render spread over machines. Shard I renders the sample indices
//! `I·spp .. (I+1)·spp` of every pixel, so the N shards draw disjoint random streams and together draw
//! exactly those of one render of `N·spp` samples; `focal merge` puts them together (see
//! docs/sharding.md).

use anyhow::{bail, Result};

/// Shard `index` of `count` (index counts from 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// Which shard, from 0.
    pub index: u32,
    /// How many shards the render has.
    pub count: u32,
}

impl Shard {
    /// Parses `I/N` with 0 ≤ I < N.
    pub fn parse(text: &str) -> Result<Shard> {
        let parsed = text.split_once('/').and_then(|(i, n)| {
            Some((i.trim().parse::<u32>().ok()?, n.trim().parse::<u32>().ok()?))
        });
        let Some((index, count)) = parsed else {
            bail!("--shard {text}: expected I/N, e.g. 0/4 (shard indices count from 0)");
        };
        if count == 0 {
            bail!("--shard {text}: the number of shards must be at least 1");
        }
        if index >= count {
            bail!(
                "--shard {text}: shard indices count from 0, so with {count} shards they are 0/{count} \
                 to {}/{count}",
                count - 1
            );
        }
        Ok(Shard { index, count })
    }

    /// The first sample index of this shard when every shard renders `spp` samples per pixel.
    pub fn first_sample(&self, spp: u32) -> Result<u32> {
        let total = self.count as u64 * spp as u64;
        if total > u32::MAX as u64 {
            bail!(
                "--shard {}/{} with --spp {spp}: all shards together would draw {total} samples per \
                 pixel, more than the {} sample indices there are",
                self.index,
                self.count,
                u32::MAX
            );
        }
        Ok(self.index * spp)
    }

    /// The sidecar's record of the shard.
    pub fn record(&self, first_sample: u32) -> serde_json::Value {
        serde_json::json!({
            "index": self.index,
            "count": self.count,
            "first_sample": first_sample,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_bounds_shards() {
        assert_eq!(Shard::parse("0/4").unwrap(), Shard { index: 0, count: 4 });
        assert_eq!(Shard::parse("3/4").unwrap().first_sample(16).unwrap(), 48);
        for bad in ["4/4", "1/0", "x/4", "1", "-1/4", "1/4/2"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        let e = Shard::parse("4/4").unwrap_err().to_string();
        assert!(e.contains("0/4 to 3/4"), "{e}");
        assert!(Shard::parse("1/2")
            .unwrap()
            .first_sample(u32::MAX / 2 + 1)
            .is_err());
    }
}
