//! The guide cannot rot: every `sh` block of README.md and docs/ runs here
//! (the set-up commands are the ones `.ci/run` runs; benchmark commands
//! must name a real bench), every `penumbra SUBCOMMAND ...` quoted in the
//! text names only options that subcommand has, and docs/reference/ is what
//! `--help` prints (`PENUMBRA_BLESS=1` rewrites it).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The subcommands with a page in docs/reference/.
const COMMANDS: &[&str] = &[
    "info",
    "trace-rays",
    "ao",
    "bake",
    "trace",
    "prt",
    "field build",
    "field info",
    "ssao",
    "raytrace",
    "sweep",
    "bench",
    "merge",
    "gen-assets",
];

/// The repository's root, where the README's commands run.
fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn penumbra() -> &'static str {
    env!("CARGO_BIN_EXE_penumbra")
}

/// README.md and every Markdown file under docs/, in a stable order.
fn doc_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let mut files = vec![root().join("README.md")];
    walk(&root().join("docs"), &mut files);
    files
}

/// A fenced code block: where it starts, its language, its text.
struct Block {
    file: PathBuf,
    line: usize,
    lang: String,
    text: String,
}

impl Block {
    fn place(&self) -> String {
        format!("{}:{}", self.file.strip_prefix(root()).unwrap().display(), self.line)
    }
}

/// The fenced blocks of `file`, and its text outside them.
fn split(file: &Path) -> (Vec<Block>, String) {
    let text = std::fs::read_to_string(file).unwrap();
    let (mut blocks, mut prose) = (Vec::new(), String::new());
    let mut open: Option<Block> = None;
    for (i, line) in text.lines().enumerate() {
        match (&mut open, line.trim_start().strip_prefix("```")) {
            (None, Some(lang)) => {
                open = Some(Block {
                    file: file.to_path_buf(),
                    line: i + 1,
                    lang: lang.trim().to_string(),
                    text: String::new(),
                })
            }
            (Some(_), Some(_)) => blocks.push(open.take().unwrap()),
            (Some(block), None) => {
                block.text.push_str(line);
                block.text.push('\n');
            }
            (None, None) => {
                prose.push_str(line);
                prose.push('\n');
            }
        }
    }
    assert!(open.is_none(), "{}: a code block is never closed", file.display());
    (blocks, prose)
}

fn sh_blocks() -> Vec<Block> {
    doc_files()
        .iter()
        .flat_map(|f| split(f).0)
        .filter(|b| b.lang == "sh")
        .collect()
}

/// The set-up commands: what `.ci/run` runs, not run here.
fn is_setup(block: &Block) -> bool {
    block.text.contains("apt-get") || block.text.contains("cargo test")
}

fn help(command: &str) -> String {
    let out = Command::new(penumbra())
        .args(command.split(' '))
        .arg("--help")
        .output()
        .unwrap();
    assert!(out.status.success(), "penumbra {command} --help failed");
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn the_reference_pages_are_what_help_prints() {
    let bless = common::bless();
    let mut stale = Vec::new();
    for command in COMMANDS {
        let page = root()
            .join("docs/reference")
            .join(format!("{}.md", command.replace(' ', "-")));
        let want = format!(
            "# `penumbra {command}`\n\n<!-- Written by crates/penumbra-cli/tests/docs.rs from `penumbra {command} --help`: \
             run it with PENUMBRA_BLESS=1 after changing an option. -->\n\n```text\n{}```\n",
            help(command)
        );
        if std::fs::read_to_string(&page).ok().as_deref() != Some(want.as_str()) {
            if bless {
                std::fs::create_dir_all(page.parent().unwrap()).unwrap();
                std::fs::write(&page, want).unwrap();
            } else {
                stale.push(page.display().to_string());
            }
        }
    }
    assert!(
        stale.is_empty(),
        "reference pages differ from --help (PENUMBRA_BLESS=1 cargo test --release --test docs rewrites them): {stale:?}"
    );
}

#[test]
fn the_set_up_commands_are_what_ci_runs() {
    let ci = std::fs::read_to_string(root().join(".ci/run")).unwrap();
    let ci_lines: Vec<&str> = ci.lines().map(str::trim).collect();
    let setup: Vec<Block> = split(&root().join("README.md"))
        .0
        .into_iter()
        .filter(is_setup)
        .collect();
    assert_eq!(setup.len(), 2, "the README names two set-up commands");
    for block in &setup {
        for line in block.text.lines().filter(|l| !l.trim().is_empty()) {
            assert!(
                ci_lines.contains(&line.trim()),
                "{}: `{line}` is not a line of .ci/run",
                block.place()
            );
        }
    }
    let commands = ci_lines.iter().filter(|l| !l.is_empty() && !l.starts_with('#'));
    let commands: Vec<_> = commands
        .filter(|l| !l.starts_with("set ") && !l.starts_with("cd "))
        .collect();
    assert_eq!(
        commands.len(),
        2,
        ".ci/run runs exactly the two set-up commands: {commands:?}"
    );
}

/// Whether a block needs the shared data: it names it, or names a file of
/// ours (a scene) that does.
fn needs_data(block: &Block) -> bool {
    let names_data = |text: &str| text.contains("shared/data") || text.contains("$PENUMBRA_DATA");
    names_data(&block.text)
        || block.text.split_whitespace().any(|word| {
            let path = root().join(word.trim_matches(['\'', '"']));
            path.is_file() && std::fs::read_to_string(&path).is_ok_and(|t| names_data(&t))
        })
}

/// What `cargo` means inside a guide block: `cargo run --release -- ARGS`
/// is `penumbra ARGS`; `cargo bench`/`cargo test` must name a real target
/// (benchmarks take minutes to hours: they are named, not run).
const CARGO_SHIM: &str = r#"
cargo() {
  case "$1" in
    run) shift; while [ "$1" != "--" ]; do shift; done; shift; penumbra "$@" ;;
    bench|test)
      local kind="$1" dir; [ "$kind" = bench ] && dir=benches || dir=tests
      local target=""; while [ $# -gt 0 ]; do
        if [ "$1" = "--$kind" ]; then target="$2"; fi; shift; done
      [ -n "$target" ] || { echo "cargo $kind without --$kind NAME"; return 1; }
      local found=""; for c in crates/penumbra crates/penumbra-cli; do
        [ -f "$ROOT/$c/$dir/$target.rs" ] && found="$c/$dir/$target.rs"; done
      [ -n "$found" ] || { echo "no crates/*/$dir/$target.rs"; return 1; }
      echo "names $found (not run here)" ;;
    *) echo "unexpected cargo $*"; return 1 ;;
  esac
}
"#;

#[test]
fn every_command_of_the_guide_runs() {
    let data = std::env::var_os("PENUMBRA_DATA")
        .map(|d| root().join(d))
        .map(|d| std::fs::canonicalize(d).expect("PENUMBRA_DATA exists"));
    let scratch = std::env::temp_dir().join(format!("penumbra-docs-{}", std::process::id()));
    let work = scratch.join("main");
    std::fs::create_dir_all(scratch.join("shared")).unwrap();
    copy_dir(&root().join("assets"), &work.join("assets"));
    if let Some(data) = &data {
        std::os::unix::fs::symlink(data, scratch.join("shared/data")).unwrap();
    }
    let bin_dir = Path::new(penumbra()).parent().unwrap();
    let path = format!("{}:{}", bin_dir.display(), std::env::var("PATH").unwrap_or_default());
    let (mut ran, mut skipped, mut failed) = (0, 0, Vec::new());
    for block in sh_blocks().iter().filter(|b| !is_setup(b)) {
        if data.is_none() && needs_data(block) {
            println!("{}: skipped (needs PENUMBRA_DATA)", block.place());
            skipped += 1;
            continue;
        }
        let started = std::time::Instant::now();
        let mut command = Command::new("bash");
        command
            .arg("-c")
            .arg(format!("set -euo pipefail\n{CARGO_SHIM}\n{}", block.text))
            .current_dir(&work)
            .env("PATH", &path)
            .env("ROOT", root())
            .env("PENUMBRA_CACHE_DIR", scratch.join("cache"));
        if let Some(data) = &data {
            command.env("PENUMBRA_DATA", data);
        }
        let out = command.output().unwrap();
        println!(
            "{}: exit {:?} in {:.1} s",
            block.place(),
            out.status.code(),
            started.elapsed().as_secs_f64()
        );
        if !out.status.success() {
            let stderr = String::from_utf8_lossy(&out.stderr);
            let stdout = String::from_utf8_lossy(&out.stdout);
            failed.push(format!("{}:\n{}\n{stdout}{stderr}", block.place(), block.text));
        }
        ran += 1;
    }
    let _ = std::fs::remove_dir_all(&scratch);
    println!("guide blocks: {ran} ran, {skipped} skipped, {} failed", failed.len());
    assert!(failed.is_empty(), "guide commands failed:\n{}", failed.join("\n"));
    // Without the shared data only the blocks on our own assets run.
    let expected = if data.is_some() { 13 } else { 5 };
    assert!(ran >= expected, "only {ran} guide blocks ran, expected {expected}");
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// `penumbra SUB ...` quoted in the text (`` `penumbra ao --rays N` ``):
/// every `--option` in it must be one `SUB --help` lists.
#[test]
fn quoted_commands_name_real_options() {
    let helps: Vec<(&str, String)> = COMMANDS.iter().map(|c| (*c, help(c))).collect();
    let mut wrong = Vec::new();
    let mut checked = 0;
    for file in doc_files() {
        let (_, prose) = split(&file);
        for span in prose.split('`').skip(1).step_by(2) {
            let Some(rest) = span.strip_prefix("penumbra ") else {
                continue;
            };
            let Some((command, text)) = helps
                .iter()
                .filter(|(c, _)| rest.starts_with(c) && rest[c.len()..].chars().next().is_none_or(|ch| ch == ' '))
                .max_by_key(|(c, _)| c.len())
            else {
                if !rest.starts_with("field ") && !rest.starts_with("SUB") {
                    wrong.push(format!("{}: `{span}`: no such subcommand", file.display()));
                }
                continue;
            };
            checked += 1;
            for option in rest.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-')) {
                let listed = text.contains(&format!("{option} ")) || text.contains(&format!("{option}\n"));
                if option.starts_with("--") && option.len() > 2 && !listed {
                    wrong.push(format!("{}: `{span}`: {command} has no {option}", file.display()));
                }
            }
        }
    }
    println!("{checked} quoted commands checked");
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    assert!(checked >= 10);
}

/// `cargo bench --bench NAME` and `cargo test ... --test NAME` quoted in the
/// text name real targets of one of the workspace's crates.
#[test]
fn quoted_cargo_targets_exist() {
    let mut missing = Vec::new();
    for file in doc_files() {
        let (_, prose) = split(&file);
        for span in prose.split('`').skip(1).step_by(2) {
            let words: Vec<&str> = span.split_whitespace().collect();
            for pair in words.windows(2) {
                let dir = match pair[0] {
                    "--bench" => "benches",
                    "--test" => "tests",
                    _ => continue,
                };
                let crates = ["crates/penumbra", "crates/penumbra-cli"];
                let target = format!("{}.rs", pair[1]);
                if !crates.iter().any(|c| root().join(c).join(dir).join(&target).is_file()) {
                    missing.push(format!("{}: `{span}`", file.display()));
                }
            }
        }
    }
    assert!(missing.is_empty(), "quoted targets that do not exist: {missing:?}");
}

/// docs/guide/sweep.md quotes what its two commands printed: the settings
/// and repeats it states are those of the command shown (its `--grid`s over
/// the method's default grid, its `--repeat`), and the SSAO image size is
/// the command's `--width`x`--height`.
#[test]
fn the_sweep_guide_quotes_its_own_commands() {
    let path = root().join("docs/guide/sweep.md");
    let (blocks, text) = split(&path);
    let commands = blocks[0].text.replace("\\\n", " ");
    let prose = text.split_whitespace().collect::<Vec<_>>().join(" ");
    let cases: [(&str, &[penumbra::tune::Knob], &str); 2] = [
        ("ssao", penumbra::ssao::tune::KNOBS, "SSAO on the bunny"),
        (
            "field",
            penumbra::field::tune::KNOBS,
            "Fields of the bunny over a ground",
        ),
    ];
    for (method, knobs, label) in cases {
        let line = commands
            .lines()
            .find(|l| l.contains(&format!("sweep {method} ")))
            .unwrap_or_else(|| panic!("no `sweep {method}` command in {}", path.display()));
        let words: Vec<&str> = line.split_whitespace().collect();
        let after = |option: &str| -> Vec<String> {
            words
                .windows(2)
                .filter(|w| w[0] == option)
                .map(|w| w[1].trim_matches('\'').to_string())
                .collect()
        };
        let settings = penumbra::tune::Grid::parse(&after("--grid"), knobs)
            .unwrap()
            .settings()
            .len();
        let repeat: u32 = after("--repeat").first().map_or(3, |r| r.parse().unwrap());
        let plural = if repeat == 1 { "" } else { "s" };
        let quote = prose
            .split(label)
            .nth(1)
            .unwrap_or_else(|| panic!("{label:?} not in {}", path.display()));
        let stated = format!("({settings} settings x {repeat} repeat{plural}");
        assert!(
            quote.starts_with(&format!(" {stated}")),
            "{}: `sweep {method}` as shown runs {stated}), the text says {:?}",
            path.display(),
            &quote[..quote.len().min(60)]
        );
        if let (Some(w), Some(h)) = (after("--width").first(), after("--height").first()) {
            let size = format!("at {w}x{h}");
            assert!(
                quote[..quote.len().min(200)].contains(&size),
                "{}: `sweep {method}` as shown draws {size}",
                path.display()
            );
        }
    }
}
