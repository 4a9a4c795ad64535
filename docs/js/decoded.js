// Marks every image with its natural width once the page has loaded (the load event
// waits for the images; a broken image has width 0), so a headless check of the built
// site (tests/test_docs.py) can see that the figures the docs build wrote are real images
// the browser decoded.
window.addEventListener("load", function () {
  document.querySelectorAll("img").forEach(function (img) {
    img.dataset.decoded = String(img.complete ? img.naturalWidth : 0);
  });
});
