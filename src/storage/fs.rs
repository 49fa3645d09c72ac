//! [`BlobStore`] on the local filesystem: one file per key under a root directory.
//!
//! Atomic writes: the bytes go to a temp file in `ROOT/.tmp/`, which is fsynced, renamed over
//! the target (same filesystem, so the rename is atomic) and the target's directory fsynced, so
//! after a crash a key holds its old bytes or all of its new ones, never a torn file.
//! Keys are [`BlobKey`]s, which cannot contain `..`, absolute paths or separators other than
//! `/`, so every path is inside the root.
use std::fs::{self, File};
use std::io::Write as _;
use std::path::{Path, PathBuf};

use super::{BlobKey, BlobStore, StoreError};

/// Blobs as files under one directory.
#[derive(Debug)]
pub struct FsBlobStore {
    /// The root; every blob is `root/<key>`.
    root: PathBuf,
    /// Temp files for atomic writes (`root/.tmp`, same filesystem as the blobs).
    tmp: PathBuf,
}

fn io(context: &str, path: &Path, e: std::io::Error) -> StoreError {
    StoreError::Blob(format!("{context} {}: {e}", path.display()))
}

impl FsBlobStore {
    /// Opens (creating) the store at `root`. Leftover temp files of a crash are removed.
    pub fn open(root: impl Into<PathBuf>) -> Result<FsBlobStore, StoreError> {
        let root = root.into();
        let tmp = root.join(".tmp");
        if tmp.exists() {
            fs::remove_dir_all(&tmp).map_err(|e| io("clearing", &tmp, e))?;
        }
        fs::create_dir_all(&tmp).map_err(|e| io("creating", &tmp, e))?;
        Ok(FsBlobStore { root, tmp })
    }

    fn path_of(&self, key: &BlobKey) -> PathBuf {
        self.root.join(key.as_str())
    }

    fn tmp_path(&self) -> PathBuf {
        self.tmp.join(uuid::Uuid::now_v7().simple().to_string())
    }

    /// Renames the fsynced `tmp` onto `key`'s path and fsyncs the directories it touched.
    fn commit(&self, tmp: &Path, key: &BlobKey) -> Result<(), StoreError> {
        let target = self.path_of(key);
        let dir = target.parent().unwrap_or(&self.root).to_path_buf();
        let existed = dir.exists();
        fs::create_dir_all(&dir).map_err(|e| io("creating", &dir, e))?;
        fs::rename(tmp, &target).map_err(|e| io("renaming onto", &target, e))?;
        sync_dir(&dir)?;
        if !existed {
            // New directories must be durable in their parents too.
            let mut d = dir.as_path();
            while let Some(parent) = d.parent() {
                sync_dir(parent)?;
                if parent == self.root {
                    break;
                }
                d = parent;
            }
        }
        Ok(())
    }
}

fn sync_dir(dir: &Path) -> Result<(), StoreError> {
    File::open(dir)
        .and_then(|f| f.sync_all())
        .map_err(|e| io("syncing", dir, e))
}

impl BlobStore for FsBlobStore {
    fn put(&self, key: &BlobKey, bytes: &[u8]) -> Result<(), StoreError> {
        let tmp = self.tmp_path();
        let result = (|| {
            let mut f = File::create(&tmp).map_err(|e| io("creating", &tmp, e))?;
            f.write_all(bytes).map_err(|e| io("writing", &tmp, e))?;
            f.sync_all().map_err(|e| io("syncing", &tmp, e))?;
            self.commit(&tmp, key)
        })();
        if result.is_err() {
            let _ = fs::remove_file(&tmp);
        }
        result
    }

    fn put_file(&self, key: &BlobKey, path: &Path) -> Result<(), StoreError> {
        File::open(path)
            .and_then(|f| f.sync_all())
            .map_err(|e| io("syncing", path, e))?;
        // Same filesystem (the spool is under the data dir): a rename. Else copy, then commit.
        let tmp = self.tmp_path();
        if fs::rename(path, &tmp).is_err() {
            let copied = fs::copy(path, &tmp)
                .and_then(|_| File::open(&tmp))
                .and_then(|f| f.sync_all());
            if let Err(e) = copied {
                let _ = fs::remove_file(&tmp);
                return Err(io("copying", path, e));
            }
            let _ = fs::remove_file(path);
        }
        let result = self.commit(&tmp, key);
        if result.is_err() {
            let _ = fs::remove_file(&tmp);
        }
        result
    }

    fn get(&self, key: &BlobKey) -> Result<Option<Vec<u8>>, StoreError> {
        let path = self.path_of(key);
        match fs::read(&path) {
            Ok(bytes) => Ok(Some(bytes)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(io("reading", &path, e)),
        }
    }

    fn delete_prefix(&self, prefix: &BlobKey) -> Result<(), StoreError> {
        let path = self.path_of(prefix);
        let result = if path.is_dir() {
            fs::remove_dir_all(&path)
        } else {
            fs::remove_file(&path)
        };
        match result {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(io("deleting", &path, e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(s: &str) -> BlobKey {
        BlobKey::new(s).unwrap()
    }

    #[test]
    fn put_get_replace_and_delete_prefix() {
        let dir = tempfile::tempdir().unwrap();
        let store = FsBlobStore::open(dir.path().join("blobs")).unwrap();
        assert_eq!(store.get(&key("jobs/a/input")).unwrap(), None);
        store.put(&key("jobs/a/input"), b"one").unwrap();
        store.put(&key("jobs/a/input"), b"two").unwrap();
        store.put(&key("jobs/a/a1/result"), b"r").unwrap();
        store.put(&key("jobs/b/input"), b"b").unwrap();
        assert_eq!(store.get(&key("jobs/a/input")).unwrap().unwrap(), b"two");
        store.delete_prefix(&key("jobs/a")).unwrap();
        assert_eq!(store.get(&key("jobs/a/input")).unwrap(), None);
        assert_eq!(store.get(&key("jobs/a/a1/result")).unwrap(), None);
        assert_eq!(store.get(&key("jobs/b/input")).unwrap().unwrap(), b"b");
        // Deleting what is not there is fine (the sweeper may run twice).
        store.delete_prefix(&key("jobs/a")).unwrap();
        // No temp file is left behind.
        assert_eq!(
            fs::read_dir(dir.path().join("blobs/.tmp")).unwrap().count(),
            0
        );
    }

    #[test]
    fn put_file_moves_the_spooled_file() {
        let dir = tempfile::tempdir().unwrap();
        let store = FsBlobStore::open(dir.path().join("blobs")).unwrap();
        let spooled = dir.path().join("upload");
        fs::write(&spooled, b"glb bytes").unwrap();
        store.put_file(&key("jobs/x/asset"), &spooled).unwrap();
        assert!(!spooled.exists());
        assert_eq!(
            store.get(&key("jobs/x/asset")).unwrap().unwrap(),
            b"glb bytes"
        );
    }

    #[test]
    fn leftover_temp_files_are_cleared_on_open() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("blobs");
        FsBlobStore::open(&root).unwrap();
        fs::write(root.join(".tmp/torn"), b"half").unwrap();
        FsBlobStore::open(&root).unwrap();
        assert!(!root.join(".tmp/torn").exists());
    }
}
