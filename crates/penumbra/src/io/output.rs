//! Writing output files so that no reader ever sees half of one: every
//! output is written to a hidden temporary file in the same folder and
//! renamed over the target only once it is complete (a rename within a
//! folder is atomic on POSIX file systems). A failed or interrupted run
//! leaves the old file (or none), never a truncated one that looks valid.
//! `frame_path` names the files of an animation. An interrupted run
//! (Ctrl-C, with `remove_unfinished`) removes the temporaries
//! it was writing, so it leaves no trace at all.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// The temporary sibling `path` is written to first.
fn temporary(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy()).unwrap_or_default();
    let hidden = format!(".{name}.penumbra-{}.tmp", std::process::id());
    path.with_file_name(hidden)
}

/// Temporaries being written now: removed on an interrupt. Renames happen
/// under this lock, so an interrupt never races one.
static UNFINISHED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

fn unfinished() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    UNFINISHED.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Removes `tmp` from the temporaries being written.
fn forget(tmp: &Path) {
    unfinished().retain(|p| p != tmp);
}

/// Removes every temporary being written now and returns how many there
/// were: what a program calls when it is interrupted (a Ctrl-C handler), so
/// that no half-written file is left. Outputs already renamed into place
/// are complete.
pub fn remove_unfinished() -> usize {
    let mut tmps = unfinished();
    let n = tmps.len();
    for tmp in tmps.drain(..) {
        let _ = std::fs::remove_file(tmp);
    }
    n
}

/// Writes `path` through `fill`, which writes the whole file into the
/// writer it is given (seekable, as image encoders need).
pub fn write_with<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<std::fs::File>) -> std::result::Result<(), String>,
{
    let mut pending = Pending::create(path)?;
    match fill(pending.writer()) {
        Ok(()) => pending.finish(),
        Err(e) => Err(pending.fail(e)),
    }
}

/// An output being written piece by piece (e.g. one animation frame at a
/// time) into its temporary sibling: `finish` renames it over `path`;
/// dropped unfinished (an error on the way), the temporary is removed and
/// `path` is left as it was.
pub struct Pending {
    path: PathBuf,
    tmp: PathBuf,
    out: Option<BufWriter<std::fs::File>>,
}

impl Pending {
    /// Opens the temporary sibling of `path` for writing; an error if
    /// `path` names a folder or the temporary cannot be created. `path`
    /// itself is untouched until [`Pending::finish`].
    pub fn create(path: &Path) -> Result<Pending> {
        if path.file_name().is_none() || path.is_dir() {
            return Err(Error::file(path, "", "is a folder, not a file name"));
        }
        let tmp = temporary(path);
        let mut tmps = unfinished();
        let file = std::fs::File::create(&tmp).map_err(|e| Error::write(path, e))?;
        tmps.push(tmp.clone());
        Ok(Pending {
            path: path.to_path_buf(),
            tmp,
            out: Some(BufWriter::new(file)),
        })
    }

    /// Where to write.
    pub fn writer(&mut self) -> &mut BufWriter<std::fs::File> {
        self.out.as_mut().expect("written after finishing")
    }

    /// The error of a failed write, the temporary removed.
    pub fn fail(mut self, e: impl std::fmt::Display) -> Error {
        self.out = None;
        let _ = std::fs::remove_file(&self.tmp);
        forget(&self.tmp);
        Error::write(&self.path, e)
    }

    /// Flushes, syncs and renames the file over `path`.
    pub fn finish(mut self) -> Result<()> {
        let out = self.out.take().expect("finished once");
        let done = (|| {
            let file = out.into_inner().map_err(|e| e.error().to_string())?;
            file.sync_all().map_err(|e| e.to_string())?;
            let mut tmps = unfinished();
            let renamed = std::fs::rename(&self.tmp, &self.path).map_err(|e| e.to_string());
            tmps.retain(|p| *p != self.tmp);
            renamed
        })();
        done.map_err(|e| {
            let _ = std::fs::remove_file(&self.tmp);
            forget(&self.tmp);
            Error::write(&self.path, e)
        })
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if self.out.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
            forget(&self.tmp);
        }
    }
}

/// Writes `bytes` to `path`.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_with(path, |out| out.write_all(bytes).map_err(|e| e.to_string()))
}

/// Writes an image in the format `format` (encoders need to seek).
#[cfg(any(feature = "png", feature = "exr"))]
pub fn write_image<W>(path: &Path, image: &W, format: image::ImageFormat) -> Result<()>
where
    W: ImageWrite,
{
    write_with(path, |out| image.encode(out, format))
}

/// An image the `image` crate can encode.
#[cfg(any(feature = "png", feature = "exr"))]
pub trait ImageWrite {
    /// Encodes the image as `format` into `out`; the error as text.
    fn encode<O: Write + std::io::Seek>(
        &self,
        out: &mut O,
        format: image::ImageFormat,
    ) -> std::result::Result<(), String>;
}

#[cfg(any(feature = "png", feature = "exr"))]
impl<P, C> ImageWrite for image::ImageBuffer<P, C>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
    C: std::ops::Deref<Target = [P::Subpixel]>,
{
    fn encode<O: Write + std::io::Seek>(
        &self,
        out: &mut O,
        format: image::ImageFormat,
    ) -> std::result::Result<(), String> {
        self.write_to(out, format).map_err(|e| e.to_string())
    }
}

/// Where frame `frame` of an animation goes (`last`: it is the last
/// frame): every frame to its own file where `template` holds `{}`, else
/// only the last frame, to `template` itself.
pub fn frame_output(template: &Path, frame: u32, last: bool) -> Option<PathBuf> {
    frame_path(template, frame).or_else(|| last.then(|| template.to_path_buf()))
}

/// The output file of frame `frame`: the template with `{}` or `{:0N}`
/// replaced by the frame number, if it holds one.
pub fn frame_path(template: &Path, frame: u32) -> Option<PathBuf> {
    let text = template.to_string_lossy();
    let open = text.find('{')?;
    let close = open + text[open..].find('}')?;
    let spec = &text[open + 1..close];
    let number = match spec.strip_prefix(":0").map(str::parse::<usize>) {
        Some(Ok(width)) => format!("{frame:0width$}"),
        _ if spec.is_empty() => frame.to_string(),
        _ => return None,
    };
    Some(PathBuf::from(format!(
        "{}{number}{}",
        &text[..open],
        &text[close + 1..]
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("penumbra-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_temporary() {
        let dir = folder("failed");
        let path = dir.join("out.bin");
        std::fs::write(&path, b"old").unwrap();
        let e = write_with(&path, |out| {
            out.write_all(b"half").map_err(|e| e.to_string())?;
            Err("interrupted".into())
        })
        .unwrap_err();
        assert!(e.to_string().contains("interrupted"), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(left.len(), 1, "only the old file is left");
    }

    #[test]
    fn a_write_replaces_the_file_whole() {
        let dir = folder("whole");
        let path = dir.join("out.bin");
        std::fs::write(&path, b"old contents").unwrap();
        write_bytes(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert!(write_bytes(&dir, b"x").is_err(), "a folder is not an output file");
    }
}
