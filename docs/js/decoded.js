// Marks every image once the browser has decoded it (data-decoded = its natural width),
// so a headless check of the built site (tests/test_docs.py) can see that the figures
// the docs build wrote are real images the browser can show.
window.addEventListener("load", function () {
  document.querySelectorAll("img").forEach(function (img) {
    img.decode().then(function () { img.dataset.decoded = String(img.naturalWidth); },
                      function () { img.dataset.decoded = "0"; });
  });
});
