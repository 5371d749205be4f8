//! `shadowlab techniques [--json]`: ids, light types, parameters with defaults and ranges.

use anyhow::Result;
use serde_json::json;

use crate::args::GlobalArgs;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(_global: &GlobalArgs, args: Args) -> Result<()> {
    let list: Vec<_> = shadowlab::registry()
        .iter()
        .map(|t| {
            json!({
                "id": t.id, "summary": t.summary, "source": t.source, "light_types": t.light_types,
                "params": t.params.iter().map(|p| json!({
                    "name": p.name, "default": p.default.to_json(), "range": p.range_text(), "doc": p.doc,
                })).collect::<Vec<_>>(),
            })
        })
        .collect();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&list)?);
        return Ok(());
    }
    for t in shadowlab::registry() {
        println!("{:<10} {}", t.id, t.summary);
        println!("{:<10} lights: {}; source: {}", "", t.light_types.join(", "), t.source);
        for p in t.params {
            println!("{:<10}   {}={} ({}): {}", "", p.name, p.default, p.range_text(), p.doc);
        }
        println!();
    }
    Ok(())
}
